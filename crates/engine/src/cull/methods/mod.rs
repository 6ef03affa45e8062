//! The methods on the wire, one type each ([`super::method::CullMethod`]); registered
//! in [`super::method::of`].

mod exact;
mod frustum;
mod hom;
mod hzb;

pub use exact::Exact;
pub use frustum::Frustum;
pub use hom::Hom;
pub use hzb::Hzb;
