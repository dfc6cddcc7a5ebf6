//! Typed ids: a robot's id, a mission's name and a node's Zenoh id are different things that
//! happen to be spelled as strings. Each is a newtype over a shared `str` (a clone, which the
//! machines make of ids at every look, costs no allocation), serialized as the bare string (the
//! wire is unchanged) and compared with strings, so that tables and tests read
//! naturally; a map keyed by one is searched with a `&str` (`Borrow<str>`). An id is not a
//! string: it does not dereference to one (`as_str()` says where a string is wanted), so a
//! robot's id cannot be passed where a mission's name is expected without anyone writing it.

use std::borrow::Borrow;
use std::fmt;
use std::sync::Arc;

use serde::{Deserialize, Deserializer, Serialize, Serializer};

/// Declares one id type with its conversions.
macro_rules! id_type {
    ($(#[$doc:meta])* $name:ident) => {
        $(#[$doc])*
        #[derive(Clone, Default, PartialEq, Eq, PartialOrd, Ord, Hash)]
        pub struct $name(Arc<str>);

        impl $name {
            /// The id as a string slice.
            pub fn as_str(&self) -> &str {
                &self.0
            }

            /// The id's string.
            pub fn into_string(self) -> String {
                self.0.to_string()
            }
        }

        /// The bare string.
        impl Serialize for $name {
            fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
                s.serialize_str(&self.0)
            }
        }

        impl<'de> Deserialize<'de> for $name {
            fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
                String::deserialize(d).map(|s| $name(s.into()))
            }
        }

        /// Quoted, as the string it is: messages and logs read as they did with bare strings.
        impl fmt::Debug for $name {
            fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
                fmt::Debug::fmt(&self.0, f)
            }
        }

        impl fmt::Display for $name {
            fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
                f.write_str(&self.0)
            }
        }

        impl AsRef<str> for $name {
            fn as_ref(&self) -> &str {
                &self.0
            }
        }

        impl Borrow<str> for $name {
            fn borrow(&self) -> &str {
                &self.0
            }
        }

        impl From<String> for $name {
            fn from(s: String) -> Self {
                $name(s.into())
            }
        }

        impl From<&str> for $name {
            fn from(s: &str) -> Self {
                $name(s.into())
            }
        }

        impl From<&&str> for $name {
            fn from(s: &&str) -> Self {
                $name((*s).into())
            }
        }

        impl From<&String> for $name {
            fn from(s: &String) -> Self {
                $name(s.as_str().into())
            }
        }

        impl From<&$name> for $name {
            fn from(s: &$name) -> Self {
                s.clone()
            }
        }

        impl From<$name> for String {
            fn from(id: $name) -> String {
                id.0.to_string()
            }
        }

        impl PartialEq<str> for $name {
            fn eq(&self, other: &str) -> bool {
                &*self.0 == other
            }
        }

        impl PartialEq<&str> for $name {
            fn eq(&self, other: &&str) -> bool {
                &*self.0 == *other
            }
        }

        impl PartialEq<String> for $name {
            fn eq(&self, other: &String) -> bool {
                &*self.0 == other.as_str()
            }
        }

        impl PartialEq<$name> for str {
            fn eq(&self, other: &$name) -> bool {
                self == &*other.0
            }
        }

        impl PartialEq<$name> for &str {
            fn eq(&self, other: &$name) -> bool {
                *self == &*other.0
            }
        }

        impl PartialEq<$name> for String {
            fn eq(&self, other: &$name) -> bool {
                self.as_str() == &*other.0
            }
        }
    };
}

id_type!(
    /// A robot's id (`mrmm/robot/<id>/…`), unique in the fleet.
    RobotId
);
id_type!(
    /// A mission's name (`mrmm/team/<mission>/…`), unique among the fleet's missions.
    MissionName
);
id_type!(
    /// A node's Zenoh id (hex), as a mission's chain and hosts name their nodes.
    NodeId
);

#[cfg(test)]
mod tests {
    use super::*;
    use std::collections::BTreeMap;

    #[test]
    fn ids_are_bare_strings_on_the_wire_and_searchable_by_str() {
        let id = RobotId::from("r1");
        assert_eq!(serde_json::to_string(&id).expect("json"), "\"r1\"");
        let back: RobotId = serde_json::from_str("\"r1\"").expect("json");
        assert_eq!(back, "r1");
        let mut m = BTreeMap::new();
        m.insert(MissionName::from("m"), 1);
        assert_eq!(m.get("m"), Some(&1));
        assert_eq!(format!("{id}"), "r1");
        assert_eq!(format!("{id:?}"), "\"r1\"", "quoted like the string it was");
        assert_eq!(serde_json::to_string(&vec![NodeId::from("a1")]).expect("json"), "[\"a1\"]");
    }
}
