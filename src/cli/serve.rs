//! `homcull serve` (and plain `homcull`): bind, serve until SIGINT/SIGTERM, drain.

use anyhow::{Context, Result};

use super::args::ServeArgs;

pub fn run(a: ServeArgs) -> Result<()> {
    let rt = tokio::runtime::Builder::new_multi_thread()
        .enable_all()
        .build()
        .context("starting the async runtime")?;
    let backend = super::open_backend(&a.backend)?;
    rt.block_on(async move {
        let listener = tokio::net::TcpListener::bind(a.addr)
            .await
            .with_context(|| format!("listening on {}", a.addr))?;
        let config = a.config().map_err(anyhow::Error::msg)?;
        let data_dir = config.data_dir.display().to_string();
        crate::server::serve(listener, config, backend, crate::server::shutdown_signal())
            .await
            .with_context(|| format!("serving (data dir {data_dir})"))?;
        eprintln!("homcull stopped");
        Ok(())
    })
}
