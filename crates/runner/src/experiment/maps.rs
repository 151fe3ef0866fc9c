//! Parameters that are a scalar or a spatial map (`alpha_h: 0.5`, a pattern, or an `.npy`
//! file), validated onto an image grid.

use super::context::{Ctx, SpecError};
use crate::io::npy;
use serde::de::{self, MapAccess, Visitor};
use serde::{Deserialize, Deserializer, Serialize};
use std::fmt;
use std::path::PathBuf;
/// A parameter that is a scalar or a spatial map.
#[derive(Debug, Clone, PartialEq, Serialize)]
#[serde(untagged)]
pub enum ParamMap {
    /// The same value everywhere.
    Scalar(f64),
    /// A pattern or a `.npy` map.
    Pattern(PatternSpec),
}

/// Pattern kinds of a [`PatternSpec`].
#[derive(Debug, Clone, Copy, Deserialize, Serialize, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum PatternKind {
    /// `value` everywhere.
    Constant,
    /// `left` on columns `< W/2`, `right` on the rest.
    LeftRight,
    /// `top` on rows `< H/2`, `bottom` on the rest.
    TopBottom,
    /// Linear from `from` (first column or row) to `to` (last) along `axis`.
    Ramp,
    /// An `[H, W]` real `.npy` file at `path` (relative to the spec file).
    Npy,
}

/// Axis of a ramp.
#[derive(Debug, Clone, Copy, Deserialize, Serialize, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum RampAxis {
    /// Varies along columns.
    Horizontal,
    /// Varies along rows.
    Vertical,
}

/// A spatial map pattern as written: `{pattern: left_right, left: 0.5, right: 2}`.
#[derive(Debug, Clone, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct PatternSpec {
    /// Which pattern.
    pub pattern: PatternKind,
    /// `constant`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub value: Option<f64>,
    /// `left_right`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub left: Option<f64>,
    /// `left_right`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub right: Option<f64>,
    /// `top_bottom`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub top: Option<f64>,
    /// `top_bottom`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub bottom: Option<f64>,
    /// `ramp`: direction.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub axis: Option<RampAxis>,
    /// `ramp`: first value.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub from: Option<f64>,
    /// `ramp`: last value.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub to: Option<f64>,
    /// `npy`: file.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub path: Option<PathBuf>,
}

impl<'de> Deserialize<'de> for ParamMap {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct V;
        impl<'de> Visitor<'de> for V {
            type Value = ParamMap;
            fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
                f.write_str("a number or a pattern mapping such as {pattern: ramp, axis: horizontal, from: 0.5, to: 2}")
            }
            fn visit_f64<E: de::Error>(self, v: f64) -> Result<ParamMap, E> {
                Ok(ParamMap::Scalar(v))
            }
            fn visit_i64<E: de::Error>(self, v: i64) -> Result<ParamMap, E> {
                Ok(ParamMap::Scalar(v as f64))
            }
            fn visit_u64<E: de::Error>(self, v: u64) -> Result<ParamMap, E> {
                Ok(ParamMap::Scalar(v as f64))
            }
            fn visit_map<A: MapAccess<'de>>(self, map: A) -> Result<ParamMap, A::Error> {
                PatternSpec::deserialize(de::value::MapAccessDeserializer::new(map))
                    .map(ParamMap::Pattern)
            }
        }
        d.deserialize_any(V)
    }
}

/// A [`ParamMap`] after validation.
#[derive(Debug, Clone, PartialEq)]
pub enum Map {
    /// One value everywhere.
    Constant(f64),
    /// Left and right halves.
    LeftRight(f64, f64),
    /// Top and bottom halves.
    TopBottom(f64, f64),
    /// Linear ramp.
    Ramp(RampAxis, f64, f64),
    /// A loaded `[H, W]` map and its file. Boxed: inline it made every map, and so every
    /// filtered-noise job of a plan, about 300 bytes larger (a plan of 100,000 jobs holds
    /// five maps each).
    File(Box<(PathBuf, ndarray::Array2<f64>)>),
}

impl Map {
    /// The map evaluated on an `h x w` grid.
    pub fn grid(&self, h: usize, w: usize) -> ndarray::Array2<f64> {
        let lerp = |a: f64, b: f64, i: usize, n: usize| {
            if n <= 1 {
                a
            } else {
                a + (b - a) * i as f64 / (n - 1) as f64
            }
        };
        ndarray::Array2::from_shape_fn((h, w), |(r, c)| match self {
            Map::Constant(v) => *v,
            Map::LeftRight(l, rv) => {
                if c < w / 2 {
                    *l
                } else {
                    *rv
                }
            }
            Map::TopBottom(t, b) => {
                if r < h / 2 {
                    *t
                } else {
                    *b
                }
            }
            Map::Ramp(RampAxis::Horizontal, a, b) => lerp(*a, *b, c, w),
            Map::Ramp(RampAxis::Vertical, a, b) => lerp(*a, *b, r, h),
            Map::File(f) => f.1[[r, c]],
        })
    }

    /// Whether the map is the same value everywhere.
    pub fn is_constant(&self) -> bool {
        match self {
            Map::Constant(_) => true,
            Map::LeftRight(a, b) | Map::TopBottom(a, b) | Map::Ramp(_, a, b) => a == b,
            Map::File(f) => f.1.iter().all(|v| *v == f.1[[0, 0]]),
        }
    }

    /// All values the map takes (for range checks).
    fn values(&self) -> Vec<f64> {
        match self {
            Map::Constant(v) => vec![*v],
            Map::LeftRight(a, b) | Map::TopBottom(a, b) | Map::Ramp(_, a, b) => vec![*a, *b],
            Map::File(f) => f.1.iter().copied().collect(),
        }
    }
}

impl ParamMap {
    /// Validates into a [`Map`] on an `h x w` grid (loads `.npy` maps).
    pub fn check(&self, ctx: &Ctx, at: &str, h: usize, w: usize) -> Result<Map, SpecError> {
        let p = match self {
            ParamMap::Scalar(v) => return Ok(Map::Constant(*v)),
            ParamMap::Pattern(p) => p,
        };
        let need = |v: Option<f64>, field: &str| {
            v.ok_or_else(|| {
                ctx.err(
                    format!("{at}.{field}"),
                    format!("pattern {} needs `{field}`", yaml_name(&p.pattern)),
                )
            })
        };
        let allowed: &[&str] = match p.pattern {
            PatternKind::Constant => &["value"],
            PatternKind::LeftRight => &["left", "right"],
            PatternKind::TopBottom => &["top", "bottom"],
            PatternKind::Ramp => &["axis", "from", "to"],
            PatternKind::Npy => &["path"],
        };
        let present = [
            ("value", p.value.is_some()),
            ("left", p.left.is_some()),
            ("right", p.right.is_some()),
            ("top", p.top.is_some()),
            ("bottom", p.bottom.is_some()),
            ("axis", p.axis.is_some()),
            ("from", p.from.is_some()),
            ("to", p.to.is_some()),
            ("path", p.path.is_some()),
        ];
        if let Some((f, _)) = present.iter().find(|(f, set)| *set && !allowed.contains(f)) {
            return Err(ctx.err(
                format!("{at}.{f}"),
                format!(
                    "`{f}` does not belong to pattern {} (it takes {})",
                    yaml_name(&p.pattern),
                    allowed.join(", ")
                ),
            ));
        }
        Ok(match p.pattern {
            PatternKind::Constant => Map::Constant(need(p.value, "value")?),
            PatternKind::LeftRight => {
                Map::LeftRight(need(p.left, "left")?, need(p.right, "right")?)
            }
            PatternKind::TopBottom => {
                Map::TopBottom(need(p.top, "top")?, need(p.bottom, "bottom")?)
            }
            PatternKind::Ramp => {
                let axis = p.axis.ok_or_else(|| {
                    ctx.err(
                        format!("{at}.axis"),
                        "pattern ramp needs `axis` (horizontal or vertical)",
                    )
                })?;
                Map::Ramp(axis, need(p.from, "from")?, need(p.to, "to")?)
            }
            PatternKind::Npy => {
                let rel = p
                    .path
                    .as_ref()
                    .ok_or_else(|| ctx.err(format!("{at}.path"), "pattern npy needs `path`"))?;
                let file = ctx.resolve(rel);
                let m = npy::read_real_map(&file)
                    .map_err(|e| ctx.err(format!("{at}.path"), e.to_string()))?;
                if m.dim() != (h, w) {
                    return Err(ctx.err(
                        format!("{at}.path"),
                        format!(
                            "{} has shape {:?}, the images are {h}x{w}",
                            file.display(),
                            m.shape()
                        ),
                    ));
                }
                Map::File(Box::new((file, m)))
            }
        })
    }
}

/// Checks every value of a map against a predicate.
pub(super) fn check_range(
    ctx: &Ctx,
    at: &str,
    m: &Map,
    ok: impl Fn(f64) -> bool,
    what: &str,
) -> Result<(), SpecError> {
    match m.values().into_iter().find(|v| !ok(*v)) {
        Some(v) => Err(ctx.err(at, format!("{what}, got {v}"))),
        None => Ok(()),
    }
}

/// The spelling of an enum value in YAML (`filtered_noise`, `left_right`).
pub(super) fn yaml_name<T: Serialize>(v: &T) -> String {
    match serde_json::to_value(v) {
        Ok(serde_json::Value::String(s)) => s,
        _ => "?".into(),
    }
}
