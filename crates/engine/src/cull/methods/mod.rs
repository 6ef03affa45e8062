//! The methods on the wire, one type each ([`CullMethod`]), and their one
//! registration ([`of`]).

mod exact;
mod frustum;
mod hom;
mod hzb;

pub use exact::Exact;
pub use frustum::Frustum;
pub use hom::Hom;
pub use hzb::Hzb;

use homcull_proto::Method;

use super::method::CullMethod;

/// The method of a wire name: the one registration of every method on the wire.
pub fn of(method: Method) -> &'static dyn CullMethod {
    match method {
        Method::Hom => &Hom,
        Method::Hzb => &Hzb,
        Method::Frustum => &Frustum,
        Method::Exact => &Exact,
    }
}

#[cfg(test)]
mod tests {
    use homcull_proto::CullOptions;

    use super::*;
    use crate::cull::method::Passes;

    #[test]
    fn every_wire_method_is_registered_under_its_own_name() {
        for m in Method::ALL {
            assert_eq!(of(m).name(), m.name());
        }
    }

    #[test]
    fn only_the_occluder_methods_prepare_occluders() {
        let o = CullOptions::default();
        for m in Method::ALL {
            let method = of(m);
            let occlusion = matches!(method.passes(&o), Some(Passes::Occlusion { .. }));
            assert_eq!(method.needs(&o).occluders, occlusion, "{}", m.name());
        }
    }
}
