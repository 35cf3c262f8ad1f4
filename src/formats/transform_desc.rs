//! An entity's or a medium's placement as scene files write it: scale, rotation and
//! translation, or a matrix. Apart from `schema.rs` so that the descriptions it holds (media)
//! can name it without naming the schema.

use serde::{Deserialize, Serialize};

type V3 = [f32; 3];

/// Scale, then rotate (degrees about x, then y, then z, fixed axes), then translate; or a
/// whole affine `matrix` instead of the three.
#[derive(Clone, Debug, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct TransformDesc {
    /// Default: `(0, 0, 0)`.
    #[serde(default, skip_serializing_if = "is_zero")]
    pub translate: V3,
    /// Degrees. Default: `(0, 0, 0)`.
    #[serde(default, skip_serializing_if = "is_zero")]
    pub rotate: V3,
    /// Default: `(1, 1, 1)`. Every component must be positive.
    #[serde(default = "white", skip_serializing_if = "is_one")]
    pub scale: V3,
    /// The local-to-world matrix, row by row: 12 numbers (three rows of four) or 16 (the
    /// last row `0 0 0 1`), as Mitsuba's `<matrix value="...">`. It replaces `translate`,
    /// `rotate` and `scale`, which must then be left out. Default: none.
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub matrix: Option<Vec<f32>>,
}

impl Default for TransformDesc {
    fn default() -> Self {
        TransformDesc {
            translate: [0.0; 3],
            rotate: [0.0; 3],
            scale: [1.0; 3],
            matrix: None,
        }
    }
}

fn is_zero(v: &V3) -> bool {
    *v == [0.0; 3]
}

fn is_one(v: &V3) -> bool {
    *v == [1.0; 3]
}

fn white() -> V3 {
    [1.0; 3]
}
