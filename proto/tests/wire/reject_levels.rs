//! Levels of detail that `Frame::validate` and `apply_delta_with_levels` refuse: one
//! level per ID, levels of kept IDs only (the decoder's refusals are in `reject.rs`).

use homcull_proto::frame::{
    Frame, FrameError, LodChanges, VisibleDelta, VisibleFull, apply_delta_with_levels,
};

#[test]
fn levels_must_be_one_per_id_and_changes_of_kept_ids() {
    let full = Frame::Full(VisibleFull {
        ids: vec![1, 2, 3],
        levels: Some(vec![0, 1]),
        ..VisibleFull::default()
    });
    let err = FrameError::LevelCount { ids: 3, levels: 2 };
    assert_eq!(full.validate(), Err(err.clone()));
    assert_eq!(err.to_string(), "3 ids but 2 levels of detail");
    let lod = |added: Vec<u8>, changed: Vec<u32>, changed_levels: Vec<u8>| VisibleDelta {
        added: vec![4],
        removed: vec![1],
        lod: Some(LodChanges {
            added,
            changed,
            changed_levels,
        }),
        ..VisibleDelta::default()
    };
    let delta_cases = [
        (
            lod(vec![], vec![], vec![]),
            FrameError::LevelCount { ids: 1, levels: 0 },
        ),
        (
            lod(vec![0], vec![2], vec![]),
            FrameError::LevelCount { ids: 1, levels: 0 },
        ),
        (
            lod(vec![0], vec![1], vec![3]),
            FrameError::ChangedNotKept { id: 1 },
        ),
        (
            lod(vec![9], vec![], vec![]),
            FrameError::BadLevel { level: 9 },
        ),
    ];
    for (d, expected) in delta_cases {
        assert_eq!(
            Frame::Delta(d.clone()).validate(),
            Err(expected.clone()),
            "{d:?}"
        );
        let (mut set, mut levels) = (vec![1, 2, 3], vec![0, 0, 0]);
        assert_eq!(
            apply_delta_with_levels(&mut set, &mut levels, &d),
            Err(expected)
        );
        assert_eq!((set, levels), (vec![1, 2, 3], vec![0, 0, 0]), "left alone");
    }
    // A changed id that is not in the set at all.
    let (mut set, mut levels) = (vec![1, 2], vec![0, 0]);
    let d = lod(vec![0], vec![7], vec![1]);
    assert_eq!(
        apply_delta_with_levels(&mut set, &mut levels, &d),
        Err(FrameError::ChangedNotKept { id: 7 })
    );
    assert_eq!(
        apply_delta_with_levels(&mut set, &mut vec![0], &d),
        Err(FrameError::LevelCount { ids: 2, levels: 1 })
    );
    // And one that applies.
    let d = lod(vec![5], vec![2], vec![3]);
    apply_delta_with_levels(&mut set, &mut levels, &d).unwrap();
    assert_eq!((set, levels), (vec![2, 4], vec![3, 5]));
}
