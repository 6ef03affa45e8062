//! The cull options, declared once ([`cull_options!`]): each option's type, its words
//! and its default on every surface that takes it ([`Surface`]). From that one list
//! come the JSON body's [`CullOptions`] (`POST /cull`, batches), the query string's
//! [`CullOptionsQuery`] (the stream; also the command line's flags, which the binary
//! reads into it), and [`CullOptions::defaults`]. A new option is one entry here and
//! its effect in the engine.
//!
//! Why two types and not one flattened into the stream's query: serde's `flatten`
//! hands a query string's values on as strings, which numbers and booleans then
//! refuse; the query type keeps every option optional instead, and
//! [`CullOptionsQuery::over`] lays what was given over a surface's defaults.

use serde::{Deserialize, Serialize};

use crate::lod::{InvalidLod, LodThresholds};
use crate::{DebVariant, Method};

#[cfg(feature = "openapi")]
use crate::LodSpec;

/// Where a cull's options come from: each has its own defaults.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Surface {
    /// A JSON body: `POST /v1/scenes/{id}/cull`, `cull/batch`, the library.
    Rest,
    /// A visibility stream's query string.
    Stream,
    /// `homcull cull` and `homcull eval`.
    Cli,
}

impl Surface {
    /// Every surface, in the order of [`cull_options!`]'s defaults.
    pub const ALL: [Surface; 3] = [Surface::Rest, Surface::Stream, Surface::Cli];
}

/// Declares the options: `name: Type = [rest, stream, cli]` defaults, with its docs.
macro_rules! cull_options {
    ($($(#[doc = $doc:literal])* $name:ident: $ty:ty = [$rest:expr, $stream:expr, $cli:expr],)*) => {
        /// How to cull: the options a client may set per request (the defaults here
        /// are a JSON body's, [`Surface::Rest`]).
        #[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
        #[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
        #[serde(default, deny_unknown_fields)]
        pub struct CullOptions {
            $($(#[doc = $doc])* pub $name: $ty,)*
            /// Level-of-detail hints (`{"px": [t1, t2, …]}`; the stream's query and the
            /// command line: `lod_px=t1,t2,…`): when given, the answer carries a level
            /// per visible object ([`crate::lod`]). It does not change what is visible.
            /// No default: none.
            #[serde(skip_serializing_if = "Option::is_none")]
            #[cfg_attr(feature = "openapi", schema(value_type = Option<LodSpec>))]
            pub lod: Option<LodThresholds>,
        }

        impl CullOptions {
            /// The defaults of `surface`.
            pub fn defaults(surface: Surface) -> Self {
                match surface {
                    Surface::Rest => CullOptions { $($name: $rest,)* lod: None },
                    Surface::Stream => CullOptions { $($name: $stream,)* lod: None },
                    Surface::Cli => CullOptions { $($name: $cli,)* lod: None },
                }
            }

            /// Every option's name, as the body, the query and the flags spell it.
            pub const NAMES: &[&str] = &[$(stringify!($name),)* "lod"];
        }

        /// The options as a query string (or flags) give them: each one optional,
        /// laid over a surface's defaults by [`CullOptionsQuery::over`].
        #[cfg_attr(feature = "openapi", derive(utoipa::IntoParams))]
        #[cfg_attr(feature = "openapi", into_params(parameter_in = Query))]
        #[derive(Debug, Clone, Default, PartialEq, Deserialize)]
        pub struct CullOptionsQuery {
            $($(#[doc = $doc])* pub $name: Option<$ty>,)*
            /// Level-of-detail thresholds in pixels, largest first (`lod_px=64,16,4`):
            /// the answer then carries a level per object it sends (see
            /// [`crate::lod`]).
            pub lod_px: Option<String>,
        }

        impl CullOptionsQuery {
            /// `base` with every option given here in its place.
            pub fn over(self, base: CullOptions) -> Result<CullOptions, InvalidLod> {
                Ok(CullOptions {
                    $($name: self.$name.unwrap_or(base.$name),)*
                    lod: match self.lod_px.as_deref() {
                        Some(list) => Some(LodThresholds::parse_list(list)?),
                        None => base.lod,
                    },
                })
            }
        }
    };
}

cull_options! {
    /// Culling method: hom (the default), hzb, frustum or exact.
    method: Method = [Method::Hom, Method::Hom, Method::Hom],
    /// Opacity threshold O_0 at the finest pyramid level, in (0, 1]; 1 (the default)
    /// is conservative, below 1 culls through small holes.
    threshold: f32 = [1.0, 1.0, 1.0],
    /// Depth estimation buffer variant used by `hom`: plane, tiles or raster (the
    /// default).
    deb: DebVariant = [DebVariant::Raster, DebVariant::Raster, DebVariant::Raster],
    /// `hom` only: test the objects that pass the box test once more, per pixel of
    /// their own triangles against the occluders. Culls nearly every hidden object a
    /// bounding box cannot; `false` is the box test alone. Default true, but false for
    /// streams: the refinement is exact for the pose sent, and a moving client that
    /// draws the answer a round trip later sees the slivers it reveals late, which the
    /// box test's slack covers.
    refine: bool = [true, false, true],
}

impl Default for CullOptions {
    fn default() -> Self {
        CullOptions::defaults(Surface::Rest)
    }
}

impl CullOptions {
    /// Checks what the types cannot: the opacity threshold lies in (0, 1]. Every entry
    /// point (REST, stream, command line, library) calls this one check.
    pub fn validate(&self) -> Result<(), InvalidOptions> {
        let t = self.threshold;
        if t > 0.0 && t <= 1.0 {
            Ok(())
        } else {
            Err(InvalidOptions::Threshold(t))
        }
    }
}

/// Why [`CullOptions::validate`] refused options.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum InvalidOptions {
    /// The opacity threshold is outside (0, 1] (or NaN).
    Threshold(f32),
}

impl std::fmt::Display for InvalidOptions {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            InvalidOptions::Threshold(t) => write!(f, "threshold must be in (0, 1], got {t}"),
        }
    }
}

impl std::error::Error for InvalidOptions {}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_query_lays_what_it_gives_over_the_surfaces_defaults() {
        let q: CullOptionsQuery =
            serde_json::from_value(serde_json::json!({"threshold": 0.5, "refine": true})).unwrap();
        let o = q.over(CullOptions::defaults(Surface::Stream)).unwrap();
        assert_eq!(o.threshold, 0.5);
        assert!(o.refine, "given over the stream's default");
        assert_eq!(o.method, Method::Hom);
    }

    #[test]
    fn an_empty_query_is_the_surfaces_defaults() {
        for s in Surface::ALL {
            let d = CullOptions::defaults(s);
            assert_eq!(CullOptionsQuery::default().over(d), Ok(d));
            assert!(d.validate().is_ok(), "{s:?}");
        }
        assert!(!CullOptions::defaults(Surface::Stream).refine);
        assert!(CullOptions::default().refine);
    }

    #[test]
    fn every_option_is_named_once() {
        let json = serde_json::to_value(CullOptions {
            lod: Some(LodThresholds::parse_list("8").unwrap()),
            ..CullOptions::default()
        })
        .unwrap();
        let keys: Vec<&str> = json
            .as_object()
            .unwrap()
            .keys()
            .map(|k| k.as_str())
            .collect();
        let mut names = CullOptions::NAMES.to_vec();
        names.sort();
        let mut keys = keys;
        keys.sort();
        assert_eq!(keys, names);
    }

    #[test]
    fn a_bad_lod_list_is_refused() {
        let q = CullOptionsQuery {
            lod_px: Some("4,16".into()),
            ..CullOptionsQuery::default()
        };
        assert!(q.over(CullOptions::default()).is_err());
    }
}
