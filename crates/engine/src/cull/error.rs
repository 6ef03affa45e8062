//! Why a cull failed, in words that name no backend.

use homcull_proto::InvalidOptions;

/// Why a cull failed.
#[derive(Debug, thiserror::Error)]
pub enum CullError {
    /// The options were refused before any work ([`homcull_proto::CullOptions::validate`]).
    #[error(transparent)]
    Options(#[from] InvalidOptions),
    /// The backend could not run the batch (a device lost, a readback that failed).
    #[error("{backend}: {message}")]
    Backend {
        /// Which backend, in words (`"GPU"`).
        backend: &'static str,
        message: String,
    },
}
