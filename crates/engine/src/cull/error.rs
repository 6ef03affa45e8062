//! Why a cull failed, in words that name no backend.

use homcull_proto::InvalidOptions;

/// Why a cull failed.
#[derive(Debug, thiserror::Error)]
pub enum CullError {
    /// The options were refused before any work ([`homcull_proto::CullOptions::validate`]).
    #[error(transparent)]
    Options(#[from] InvalidOptions),
    /// The method does not run on this backend (`CullMethod::runs_on`).
    #[error("method `{method}` does not run on the {backend} backend")]
    Unsupported {
        method: &'static str,
        /// The backend's short name (`Culler::name`).
        backend: &'static str,
    },
    /// The method does not answer for a region of eyes (`exact`: the oracle is
    /// one eye's).
    #[error("method `{method}` does not take a region")]
    RegionUnsupported { method: &'static str },
    /// The backend could not run the batch (a device lost, a readback that failed).
    #[error("{backend}: {message}")]
    Backend {
        /// Which backend, in words (`"GPU"`).
        backend: &'static str,
        message: String,
    },
}
