//! Load generator (placeholder until written).
use crate::config::LoadgenArgs;

pub fn main(_a: LoadgenArgs) -> anyhow::Result<()> {
    anyhow::bail!("loadgen is not implemented yet")
}
