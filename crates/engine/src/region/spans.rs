//! The cells of one row of a map that a convex polygon's edge tests pass, found
//! without testing every cell of the polygon's bounding rect.
//!
//! A region map draws each occluder into the cells it covers whole (its covers) and
//! into those it touches; both are conjunctions of one test per edge, evaluated at
//! the cell corner the edge's normal picks (`nx·X + ny·Y + k` against a margin). On a
//! row, `Y` is fixed and `X` moves with the cell in one direction, and f32
//! multiplication and addition are monotone, so each edge's test passes on a run of
//! cells that reaches one end of the row, and the conjunction on one run. Each
//! edge's end of it is found by stepping from the solution of its line equation
//! (f64) with the test itself, so the run is exactly the cells the per-cell test
//! would pass (for finite edge functions; others give no cover and touch every
//! cell): the maps drawn this way are those the cell-by-cell loops drew, and a thin
//! diagonal triangle costs its own cells, not its bounding rect's.

/// Which test an edge function `nx·x + ny·y + k` (positive inside) must pass on a
/// cell `[x0, x1] × [y0, y1]`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) enum EdgeTest {
    /// Positive over the whole cell by the margin (times `|nx| + |ny|`): at the
    /// corner the normal points away from.
    Holds(f32),
    /// Not negative over the whole cell by more than the margin: at the corner the
    /// normal points to.
    Meets(f32),
}

impl EdgeTest {
    /// The coordinate of the cell `[lo, hi]` on one axis that the test reads for an
    /// edge normal component `n`: the side the normal points away from (`Holds`) or
    /// to (`Meets`).
    fn corner(self, n: f32, lo: f32, hi: f32) -> f32 {
        match (self, n >= 0.0) {
            (EdgeTest::Holds(_), true) | (EdgeTest::Meets(_), false) => lo,
            (EdgeTest::Holds(_), false) | (EdgeTest::Meets(_), true) => hi,
        }
    }

    /// Whether edge `[nx, ny, k]` passes on the cell (the one formula every map
    /// drawing uses).
    pub(super) fn passes(self, [nx, ny, k]: [f32; 3], [x0, x1, y0, y1]: [f32; 4]) -> bool {
        let (x, y) = (self.corner(nx, x0, x1), self.corner(ny, y0, y1));
        let v = nx * x + ny * y + k;
        match self {
            EdgeTest::Holds(m) => v > m * (nx.abs() + ny.abs()),
            // Not below: also where it is not a number.
            EdgeTest::Meets(m) => {
                v.partial_cmp(&(-m * (nx.abs() + ny.abs()))) != Some(std::cmp::Ordering::Less)
            }
        }
    }

    /// Whether every edge passes on the cell.
    pub(super) fn all(self, edges: &[[f32; 3]], cell: [f32; 4]) -> bool {
        edges.iter().all(|&e| self.passes(e, cell))
    }
}

/// Rows narrower than this many cells are scanned, not solved.
const NARROW: usize = 8;

/// The cells `[a, b]` of row `cy` within `[cx0, cx1]` on which every edge passes
/// `test`; `None` when there are none.
pub(super) fn row_span(
    edges: &[[f32; 3]],
    test: EdgeTest,
    cy: usize,
    [cx0, cx1]: [usize; 2],
) -> Option<(usize, usize)> {
    let (y0, y1) = (cy as f32, cy as f32 + 1.0);
    let cell = |x: usize| [x as f32, x as f32 + 1.0, y0, y1];
    let (mut a, mut b) = (cx0, cx1);
    if b - a < NARROW {
        // A few cells: scanned from both ends, the cheaper way.
        let pass = |x: usize| test.all(edges, cell(x));
        a = (a..=b).find(|&x| pass(x))?;
        b = (a..=b).rev().find(|&x| pass(x))?;
        return Some((a, b));
    }
    for &e in edges {
        let [nx, ny, k] = e;
        let pass = |x: usize| test.passes(e, cell(x));
        if !e.iter().all(|v| v.is_finite()) {
            // Not expected from finite pixels; either way the conservative side: no
            // cover, every cell touched.
            match test {
                EdgeTest::Holds(_) => return None,
                EdgeTest::Meets(_) => continue,
            }
        }
        if nx == 0.0 {
            // Constant along the row.
            if !pass(a) {
                return None;
            }
            continue;
        }
        // Where the edge's line crosses the row (at the y its test reads), as a guess.
        let y = test.corner(ny, y0, y1);
        let guess = -(f64::from(ny) * f64::from(y) + f64::from(k)) / f64::from(nx);
        let g = guess.floor().clamp(a as f64, b as f64) as usize;
        if nx > 0.0 {
            // Rising: the run is [least passing x, b].
            a = first_rising(a, b, g, &pass)?;
        } else {
            b = last_falling(a, b, g, &pass)?;
        }
    }
    (a <= b).then_some((a, b))
}

/// The least `x` of `[a, b]` where `pass` (false, then true) holds, stepping from `g`.
fn first_rising(a: usize, b: usize, mut g: usize, pass: &impl Fn(usize) -> bool) -> Option<usize> {
    if pass(g) {
        while g > a && pass(g - 1) {
            g -= 1;
        }
        Some(g)
    } else {
        while g < b {
            g += 1;
            if pass(g) {
                return Some(g);
            }
        }
        None
    }
}

/// The greatest `x` of `[a, b]` where `pass` (true, then false) holds, stepping from
/// `g`.
fn last_falling(a: usize, b: usize, mut g: usize, pass: &impl Fn(usize) -> bool) -> Option<usize> {
    if pass(g) {
        while g < b && pass(g + 1) {
            g += 1;
        }
        Some(g)
    } else {
        while g > a {
            g -= 1;
            if pass(g) {
                return Some(g);
            }
        }
        None
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Edge functions of a triangle, positive inside (as the map's drawing makes them).
    fn edges(p: [[f32; 2]; 3]) -> [[f32; 3]; 3] {
        let [a, b, c] = p;
        let area = (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0]);
        let sign = if area >= 0.0 { 1.0 } else { -1.0 };
        std::array::from_fn(|i| {
            let (a, b) = (p[i], p[(i + 1) % 3]);
            let (nx, ny) = ((a[1] - b[1]) * sign, (b[0] - a[0]) * sign);
            [nx, ny, -(nx * a[0] + ny * a[1])]
        })
    }

    #[test]
    fn runs_are_exactly_the_cells_the_cell_test_passes() {
        let mut s = 0x2545_f491_4f6c_dd1du64;
        let mut next = |scale: f32| {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            (s >> 40) as f32 / (1u64 << 24) as f32 * scale
        };
        let (w, h) = (64usize, 48usize);
        let mut cells = 0;
        for k in 0..3000 {
            // Small, large, thin and far off-map triangles, and axis-aligned edges.
            let scale = [8.0, 80.0, 3000.0][k % 3];
            let mut p: [[f32; 2]; 3] =
                std::array::from_fn(|_| [next(scale) - scale / 4.0, next(scale) - scale / 4.0]);
            if k % 7 == 0 {
                p[1][1] = p[0][1];
            }
            if k % 11 == 0 {
                p[2][0] = p[1][0];
            }
            let e = edges(p);
            for test in [EdgeTest::Holds(1e-3), EdgeTest::Meets(1e-3)] {
                for cy in 0..h {
                    let cx = [next(w as f32) as usize, w - 1];
                    let want: Vec<usize> = (cx[0]..=cx[1])
                        .filter(|&x| {
                            test.all(&e, [x as f32, x as f32 + 1.0, cy as f32, cy as f32 + 1.0])
                        })
                        .collect();
                    let got: Vec<usize> = row_span(&e, test, cy, cx)
                        .map(|(a, b)| (a..=b).collect())
                        .unwrap_or_default();
                    assert_eq!(got, want, "{p:?} {test:?} row {cy} of {cx:?}");
                    cells += want.len();
                }
            }
        }
        assert!(cells > 10_000, "the triangles should cover cells: {cells}");
    }
}
