//! `gweave mix`'s `[purge]` table: mix's own keys and the purge motion's (the keys of
//! purge-shift's `[block]`, one type: [`PurgeMotion`]) side by side in one table, each error at
//! its own key.
//!
//! `#[serde(flatten)]` would do the same with less code, but serde reads a flattened table
//! whole before any key is looked at, so the TOML reader can no longer say where an error is:
//! an unknown key or a wrong type was reported at the `[purge]` header, and an unknown key
//! without the list of keys. Here each key is sorted as the reader reaches it: mix's own go to
//! [`PurgeConfig`]'s derived reader, the motion's (all numbers) are read where they stand and
//! handed to [`PurgeMotion`]'s, and any other is refused at its own line with every key listed.

use std::fmt;
use std::sync::OnceLock;

use serde::de::{self, DeserializeSeed, Deserializer, IntoDeserializer, MapAccess, Visitor};
use serde::Deserialize;

use super::profile::PurgeConfig;
use crate::post::purge_block::PurgeMotion;
use crate::settings::keys_of;

impl<'de> Deserialize<'de> for PurgeConfig {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        d.deserialize_map(PurgeTable)
    }
}

struct PurgeTable;

impl<'de> Visitor<'de> for PurgeTable {
    type Value = PurgeConfig;

    fn expecting(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str("the [purge] table")
    }

    fn visit_map<A: MapAccess<'de>>(self, map: A) -> Result<PurgeConfig, A::Error> {
        let mut motion = toml::Table::new();
        // The derived reader (`serde(remote = "Self")`) sees mix's own keys only.
        let mut config = PurgeConfig::deserialize(OwnKeys { map, motion: &mut motion })?;
        // Numbers the reader has checked, under keys of the motion: this cannot fail.
        config.motion = toml::Value::Table(motion).try_into().map_err(de::Error::custom)?;
        Ok(config)
    }
}

/// The table, as the derived reader of [`PurgeConfig`] sees it.
struct OwnKeys<'a, A> {
    map: A,
    /// The motion's keys met so far, with their values.
    motion: &'a mut toml::Table,
}

impl<'de, A: MapAccess<'de>> Deserializer<'de> for OwnKeys<'_, A> {
    type Error = A::Error;

    fn deserialize_any<V: Visitor<'de>>(self, _: V) -> Result<V::Value, A::Error> {
        Err(de::Error::custom("the [purge] table is read as a struct"))
    }

    fn deserialize_struct<V: Visitor<'de>>(
        self,
        _name: &'static str,
        own: &'static [&'static str],
        visitor: V,
    ) -> Result<V::Value, A::Error> {
        visitor.visit_map(Sorted { map: self.map, own, motion: self.motion })
    }

    serde::forward_to_deserialize_any! {
        bool i8 i16 i32 i64 i128 u8 u16 u32 u64 u128 f32 f64 char str string bytes byte_buf option
        unit unit_struct newtype_struct seq tuple tuple_struct map enum identifier ignored_any
    }
}

/// The table's entries with the motion's taken out.
struct Sorted<'a, A> {
    map: A,
    /// Mix's own keys.
    own: &'static [&'static str],
    motion: &'a mut toml::Table,
}

impl<'de, A: MapAccess<'de>> MapAccess<'de> for Sorted<'_, A> {
    type Error = A::Error;

    fn next_key_seed<K: DeserializeSeed<'de>>(&mut self, seed: K) -> Result<Option<K::Value>, A::Error> {
        // The key is sorted inside the reader's own key step, so that an unknown key is
        // reported where it stands.
        while let Some(key) = self.map.next_key_seed(Key { own: self.own })? {
            match key {
                Sort::Own(name) => return seed.deserialize(name.into_deserializer()).map(Some),
                Sort::Motion(name) => {
                    let value: f64 = self.map.next_value()?;
                    self.motion.insert(name.to_owned(), toml::Value::Float(value));
                }
            }
        }
        Ok(None)
    }

    fn next_value_seed<V: DeserializeSeed<'de>>(&mut self, seed: V) -> Result<V::Value, A::Error> {
        self.map.next_value_seed(seed)
    }
}

/// Whose key a key of the table is.
enum Sort {
    Own(&'static str),
    Motion(&'static str),
}

/// Reads a key and sorts it.
struct Key {
    own: &'static [&'static str],
}

impl<'de> DeserializeSeed<'de> for Key {
    type Value = Sort;

    fn deserialize<D: Deserializer<'de>>(self, d: D) -> Result<Sort, D::Error> {
        let name = String::deserialize(d)?;
        let find = |keys: &'static [&'static str]| keys.iter().copied().find(|k| *k == name);
        if let Some(own) = find(self.own) {
            return Ok(Sort::Own(own));
        }
        if let Some(motion) = find(keys_of::<PurgeMotion>()) {
            return Ok(Sort::Motion(motion));
        }
        // Every key, mix's own first, as a plain table's error lists them.
        static ALL: OnceLock<Vec<&'static str>> = OnceLock::new();
        let all = ALL.get_or_init(|| self.own.iter().chain(keys_of::<PurgeMotion>()).copied().collect());
        Err(de::Error::unknown_field(&name, all))
    }
}
