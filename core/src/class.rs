//! Object classes, with the KITTI type names they come from: what an object is, on the wire
//! (one byte) and in every file, and so which agent type forecasts it
//! (`predict::Dynamics::of_class`).

use postcard::experimental::max_size::MaxSize;
use serde::{Deserialize, Serialize};

/// What an object (or a track's owner) is.
///
/// The variants are KITTI's object types plus [`ObjectClass::Background`] for the static scene.
/// KITTI's `DontCare` regions are not objects and have no class. On the wire a class is its
/// variant index (one byte), so variants may only ever be appended.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize, MaxSize)]
pub enum ObjectClass {
    /// The static scene: not an object (tracks with object id 0).
    Background,
    /// KITTI `Car`.
    Car,
    /// KITTI `Van`.
    Van,
    /// KITTI `Truck`.
    Truck,
    /// KITTI `Pedestrian`.
    Pedestrian,
    /// KITTI `Person_sitting`.
    PersonSitting,
    /// KITTI `Cyclist`.
    Cyclist,
    /// KITTI `Tram`.
    Tram,
    /// KITTI `Misc`.
    Misc,
}

impl ObjectClass {
    /// Every class, in wire order.
    pub const ALL: [Self; 9] = [
        Self::Background,
        Self::Car,
        Self::Van,
        Self::Truck,
        Self::Pedestrian,
        Self::PersonSitting,
        Self::Cyclist,
        Self::Tram,
        Self::Misc,
    ];

    /// The classes forecast by default: vehicles and cyclists (the unicycle's agents; the
    /// paper's sequence 0000 objects are a van and a cyclist) and pedestrians (the single
    /// integrator's). Sitting persons and `Misc` do not move as agents do.
    pub const FORECAST: [Self; 6] = [Self::Car, Self::Van, Self::Truck, Self::Tram, Self::Cyclist, Self::Pedestrian];

    /// Every KITTI object type ([`Self::ALL`] without [`Self::Background`]).
    pub const KITTI: [Self; 8] = [
        Self::Car,
        Self::Van,
        Self::Truck,
        Self::Pedestrian,
        Self::PersonSitting,
        Self::Cyclist,
        Self::Tram,
        Self::Misc,
    ];

    /// The class of a KITTI label `type` string (the tracking benchmark's `Person` is
    /// `PersonSitting`); `None` for `DontCare` and anything unknown.
    /// `Background` is not a KITTI type, so its name is not accepted here.
    #[must_use]
    pub fn from_kitti_name(name: &str) -> Option<Self> {
        if name == "Person" {
            return Some(Self::PersonSitting);
        }
        Self::KITTI.into_iter().find(|c| c.kitti_name() == name)
    }

    /// The KITTI label `type` string of this class. `Background` has none in KITTI and
    /// answers `"Background"`, which no KITTI file contains.
    #[must_use]
    pub const fn kitti_name(&self) -> &'static str {
        match self {
            Self::Background => "Background",
            Self::Car => "Car",
            Self::Van => "Van",
            Self::Truck => "Truck",
            Self::Pedestrian => "Pedestrian",
            Self::PersonSitting => "Person_sitting",
            Self::Cyclist => "Cyclist",
            Self::Tram => "Tram",
            Self::Misc => "Misc",
        }
    }

    /// True for people: pedestrians and sitting persons, who step sideways and turn on the spot.
    #[must_use]
    pub const fn is_person(&self) -> bool {
        matches!(self, Self::Pedestrian | Self::PersonSitting)
    }

    /// True for motor vehicles and trams: car, van, truck, tram. Cyclists and pedestrians are
    /// vulnerable road users and are kept apart from vehicles when selecting and scoring.
    #[must_use]
    pub const fn is_vehicle(&self) -> bool {
        matches!(self, Self::Car | Self::Van | Self::Truck | Self::Tram)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn kitti_names_round_trip_and_background_is_not_kitti() {
        for c in ObjectClass::ALL.into_iter().skip(1) {
            assert_eq!(ObjectClass::from_kitti_name(c.kitti_name()), Some(c));
        }
        assert_eq!(ObjectClass::from_kitti_name("Background"), None);
        assert_eq!(ObjectClass::from_kitti_name("DontCare"), None);
        assert_eq!(ObjectClass::from_kitti_name("car"), None);
        assert_eq!(ObjectClass::from_kitti_name("Person_sitting"), Some(ObjectClass::PersonSitting));
        assert_eq!(ObjectClass::from_kitti_name("Person"), Some(ObjectClass::PersonSitting));
        assert_eq!(&ObjectClass::ALL[1..], &ObjectClass::KITTI[..]);
        let vehicles = ObjectClass::ALL.into_iter().filter(ObjectClass::is_vehicle).count();
        assert_eq!(vehicles, 4);
        assert!(!ObjectClass::Cyclist.is_vehicle());
    }
}
