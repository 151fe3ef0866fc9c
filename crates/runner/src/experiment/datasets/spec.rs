//! A `datasets:` entry as written: `id`, `kind`, and the kind's own fields, parsed by the
//! kind's `Spec` straight from the YAML parser (so an error inside a field keeps its line and
//! column). A field of another kind is refused as not applying to this one, any other unknown
//! field as serde refuses it ("unknown field `x`, expected one of ..."), each at its own YAML
//! path.

use super::super::context::{Ctx, SpecError};
use super::registry::{Dataset, KindSpec, KIND_FIELDS, KIND_NAMES};
use crate::stats::analysis::check_levels;
use serde::de::{self, DeserializeSeed, IntoDeserializer, MapAccess, Visitor};
use serde::{Deserialize, Deserializer, Serialize, Serializer};
use std::fmt;

/// One dataset entry as written.
#[derive(Debug, Clone, PartialEq)]
pub struct DatasetSpec {
    /// Identifier used in job ids and tables.
    pub id: String,
    /// Its kind and the kind's fields.
    pub kind: KindSpec,
}

impl Serialize for DatasetSpec {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        use serde::ser::SerializeMap;
        let fields = self.kind.to_value();
        let fields = fields.as_mapping().cloned().unwrap_or_default();
        let mut m = s.serialize_map(Some(2 + fields.len()))?;
        m.serialize_entry("id", &self.id)?;
        m.serialize_entry("kind", self.kind.name())?;
        for (k, v) in &fields {
            m.serialize_entry(k, v)?;
        }
        m.end()
    }
}

impl<'de> Deserialize<'de> for DatasetSpec {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        d.deserialize_map(EntryVisitor)
    }
}

struct EntryVisitor;

impl<'de> Visitor<'de> for EntryVisitor {
    type Value = DatasetSpec;

    fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
        // As serde names a derived struct (what the entry was before the kinds had files).
        f.write_str("struct DatasetSpec")
    }

    fn visit_map<A: MapAccess<'de>>(self, mut map: A) -> Result<DatasetSpec, A::Error> {
        let mut id: Option<String> = None;
        let mut before = Vec::new();
        let kind = loop {
            let Some(key) = map.next_key::<String>()? else {
                return Err(de::Error::missing_field("kind"));
            };
            match key.as_str() {
                "id" => id = Some(map.next_value()?),
                "kind" => break map.next_value_seed(KindName)?,
                // A field written before `kind`: kept, and parsed with the kind's fields.
                _ => before.push((key, map.next_value::<serde_yaml_ng::Value>()?)),
            }
        };
        let fields = KindSpec::fields_of(&kind).expect("a registered kind");
        let rest = Rest {
            map: &mut map,
            before: before.into_iter(),
            value: None,
            id: &mut id,
            kind: &kind,
            fields,
        };
        let spec = KindSpec::parse(&kind, de::value::MapAccessDeserializer::new(rest))?;
        let id = id.ok_or_else(|| de::Error::missing_field("id"))?;
        Ok(DatasetSpec { id, kind: spec })
    }
}

/// The `kind:` value: a registered kind's name.
struct KindName;

impl<'de> DeserializeSeed<'de> for KindName {
    type Value = String;
    fn deserialize<D: Deserializer<'de>>(self, d: D) -> Result<String, D::Error> {
        // Checked by the visitor, so that the parser locates an unknown name at its line.
        d.deserialize_str(self)
    }
}

impl Visitor<'_> for KindName {
    type Value = String;

    fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
        f.write_str("a dataset kind")
    }

    fn visit_str<E: de::Error>(self, name: &str) -> Result<String, E> {
        if KIND_NAMES.contains(&name) {
            Ok(name.to_string())
        } else {
            Err(E::unknown_variant(name, KIND_NAMES))
        }
    }
}

/// A refusal raised as the value of the key it concerns (so that its path and line are the
/// value's: the YAML parser locates an error its visitor raises).
struct Refuse(String);

impl<'de> DeserializeSeed<'de> for Refuse {
    type Value = ();
    fn deserialize<D: Deserializer<'de>>(self, d: D) -> Result<(), D::Error> {
        d.deserialize_any(self)
    }
}

/// Every `visit_*` of [`Refuse`] refuses.
macro_rules! refuse {
    ($($name:ident($($t:ty)?);)+) => {
        $(fn $name<E: de::Error>(self $(, _: $t)?) -> Result<(), E> {
            Err(E::custom(self.0))
        })+
    };
}

impl<'de> Visitor<'de> for Refuse {
    type Value = ();

    fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
        f.write_str(&self.0)
    }

    refuse! {
        visit_bool(bool);
        visit_i64(i64);
        visit_u64(u64);
        visit_i128(i128);
        visit_u128(u128);
        visit_f64(f64);
        visit_str(&str);
        visit_bytes(&[u8]);
        visit_unit();
        visit_none();
    }

    fn visit_some<D: Deserializer<'de>>(self, _: D) -> Result<(), D::Error> {
        Err(de::Error::custom(self.0))
    }

    fn visit_newtype_struct<D: Deserializer<'de>>(self, _: D) -> Result<(), D::Error> {
        Err(de::Error::custom(self.0))
    }

    fn visit_seq<S: de::SeqAccess<'de>>(self, _: S) -> Result<(), S::Error> {
        Err(de::Error::custom(self.0))
    }

    fn visit_map<M: MapAccess<'de>>(self, _: M) -> Result<(), M::Error> {
        Err(de::Error::custom(self.0))
    }

    fn visit_enum<E: de::EnumAccess<'de>>(self, _: E) -> Result<(), E::Error> {
        Err(de::Error::custom(self.0))
    }
}

/// The entry's remaining entries as the kind's `Spec` reads them: the fields written before
/// `kind`, then the rest of the map, with `id` taken aside and keys the kind does not take
/// refused.
struct Rest<'a, A> {
    map: &'a mut A,
    before: std::vec::IntoIter<(String, serde_yaml_ng::Value)>,
    value: Option<serde_yaml_ng::Value>,
    id: &'a mut Option<String>,
    kind: &'a str,
    fields: &'static [&'static str],
}

impl<A> Rest<'_, A> {
    /// Why `key` is not a field of this kind.
    fn refusal(&self, key: &str) -> String {
        if KIND_FIELDS.iter().any(|f| f.contains(&key)) {
            format!(
                "`{key}` does not apply to this dataset (kind {}); it takes: {}",
                self.kind,
                self.fields.join(", ")
            )
        } else {
            <serde_yaml_ng::Error as de::Error>::unknown_field(key, self.fields).to_string()
        }
    }
}

impl<'de, A: MapAccess<'de>> MapAccess<'de> for Rest<'_, A> {
    type Error = A::Error;

    fn next_key_seed<K: DeserializeSeed<'de>>(
        &mut self,
        seed: K,
    ) -> Result<Option<K::Value>, A::Error> {
        if let Some((key, value)) = self.before.next() {
            if !self.fields.contains(&key.as_str()) {
                return Err(de::Error::custom(format!("{key}: {}", self.refusal(&key))));
            }
            self.value = Some(value);
            return seed.deserialize(key.into_deserializer()).map(Some);
        }
        loop {
            let Some(key) = self.map.next_key::<String>()? else {
                return Ok(None);
            };
            match key.as_str() {
                "id" => *self.id = Some(self.map.next_value()?),
                "kind" => {
                    self.map
                        .next_value_seed(Refuse("`kind` is given twice".into()))?;
                }
                k if self.fields.contains(&k) => {
                    return seed.deserialize(key.into_deserializer()).map(Some);
                }
                k => {
                    let why = self.refusal(k);
                    self.map.next_value_seed(Refuse(why))?;
                }
            }
        }
    }

    fn next_value_seed<V: DeserializeSeed<'de>>(&mut self, seed: V) -> Result<V::Value, A::Error> {
        match self.value.take() {
            Some(v) => seed.deserialize(v).map_err(de::Error::custom),
            None => self.map.next_value_seed(seed),
        }
    }
}

impl DatasetSpec {
    /// Validates one dataset (`at` is its YAML path, e.g. `datasets[0]`): its id, its kind's
    /// fields, at least 2 samples, and `levels` within its image size.
    ///
    /// # Errors
    /// A [`SpecError`] at the offending field's YAML path.
    pub fn check(&self, ctx: &Ctx, at: &str, levels: usize) -> Result<Dataset, SpecError> {
        if self.id.is_empty()
            || !self
                .id
                .chars()
                .all(|c| c.is_ascii_alphanumeric() || "_-".contains(c))
        {
            return Err(ctx.err(
                format!("{at}.id"),
                format!(
                    "dataset id {:?} must be non-empty ASCII letters, digits, `_` or `-`",
                    self.id
                ),
            ));
        }
        let dataset = self.kind.check(ctx, at)?;
        let (n, h, w) = dataset.shape();
        if n < 2 {
            return Err(ctx.err(
                format!("{at}.{}", self.kind.samples_field()),
                format!("the stack has {n} sample(s); at least 2 are needed"),
            ));
        }
        check_levels(levels, h, w)
            .map_err(|e| ctx.err("analysis.levels", format!("dataset {}: {e}", self.id)))?;
        Ok(dataset)
    }

    /// The fields that apply to this dataset besides `id` and `kind`.
    pub fn fields(&self) -> &'static [&'static str] {
        self.kind.applies()
    }
}
