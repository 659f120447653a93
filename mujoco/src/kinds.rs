//! MuJoCo's type codes of joints, geoms, transmissions, equality constraints and constraint rows, as enums: callers
//! match on names, never on `ffi` constants.

use std::fmt;

use mujoco_sys::ffi;

/// Declares an enum over MuJoCo codes, with its conversion from the raw code and its name for messages.
macro_rules! mujoco_enum {
    ($(#[$doc:meta])* $name:ident { $($variant:ident = $raw:path => $text:literal),+ $(,)? }) => {
        $(#[$doc])*
        #[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
        pub enum $name {
            $($variant),+
        }

        impl $name {
            /// The kind of MuJoCo's code `raw`, if MuJoCo 2.2 has one.
            pub fn from_raw(raw: i32) -> Option<$name> {
                $(if raw == $raw as i32 {
                    return Some($name::$variant);
                })+
                None
            }

            /// MuJoCo's code of this kind.
            pub fn raw(self) -> i32 {
                match self {
                    $($name::$variant => $raw as i32),+
                }
            }

            /// From a code MuJoCo's own compiler or solver wrote (always one of its kinds).
            pub(crate) fn of(raw: i32) -> $name {
                $name::from_raw(raw)
                    .unwrap_or_else(|| panic!("MuJoCo wrote {} code {raw}, which 2.2 does not define", stringify!($name)))
            }
        }

        impl fmt::Display for $name {
            fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
                f.write_str(match self {
                    $($name::$variant => $text),+
                })
            }
        }
    };
}

mujoco_enum! {
    /// A joint's type (`mjtJoint`).
    JointType {
        Free = ffi::mjJNT_FREE => "free",
        Ball = ffi::mjJNT_BALL => "ball",
        Slide = ffi::mjJNT_SLIDE => "slide",
        Hinge = ffi::mjJNT_HINGE => "hinge",
    }
}

mujoco_enum! {
    /// A geom's shape (`mjtGeom`).
    GeomType {
        Plane = ffi::mjGEOM_PLANE => "plane",
        Hfield = ffi::mjGEOM_HFIELD => "hfield",
        Sphere = ffi::mjGEOM_SPHERE => "sphere",
        Capsule = ffi::mjGEOM_CAPSULE => "capsule",
        Ellipsoid = ffi::mjGEOM_ELLIPSOID => "ellipsoid",
        Cylinder = ffi::mjGEOM_CYLINDER => "cylinder",
        Box = ffi::mjGEOM_BOX => "box",
        Mesh = ffi::mjGEOM_MESH => "mesh",
    }
}

mujoco_enum! {
    /// The friction cone of contacts (`mjtCone`).
    Cone {
        Pyramidal = ffi::mjCONE_PYRAMIDAL => "pyramidal",
        Elliptic = ffi::mjCONE_ELLIPTIC => "elliptic",
    }
}

mujoco_enum! {
    /// The constraint solver (`mjtSolver`).
    Solver {
        Pgs = ffi::mjSOL_PGS => "PGS",
        Cg = ffi::mjSOL_CG => "CG",
        Newton = ffi::mjSOL_NEWTON => "Newton",
    }
}

mujoco_enum! {
    /// What an actuator drives (`mjtTrn`).
    Transmission {
        Joint = ffi::mjTRN_JOINT => "joint",
        JointInParent = ffi::mjTRN_JOINTINPARENT => "joint in parent frame",
        SliderCrank = ffi::mjTRN_SLIDERCRANK => "slider-crank",
        Tendon = ffi::mjTRN_TENDON => "tendon",
        Site = ffi::mjTRN_SITE => "site",
    }
}

mujoco_enum! {
    /// An equality constraint's type (`mjtEq`).
    EqualityType {
        Connect = ffi::mjEQ_CONNECT => "connect",
        Weld = ffi::mjEQ_WELD => "weld",
        Joint = ffi::mjEQ_JOINT => "joint",
        Tendon = ffi::mjEQ_TENDON => "tendon",
        Distance = ffi::mjEQ_DISTANCE => "distance",
    }
}

mujoco_enum! {
    /// A row of the constraint solver (`mjtConstraint`).
    ConstraintType {
        Equality = ffi::mjCNSTR_EQUALITY => "equality",
        FrictionDof = ffi::mjCNSTR_FRICTION_DOF => "dof friction",
        FrictionTendon = ffi::mjCNSTR_FRICTION_TENDON => "tendon friction",
        LimitJoint = ffi::mjCNSTR_LIMIT_JOINT => "joint limit",
        LimitTendon = ffi::mjCNSTR_LIMIT_TENDON => "tendon limit",
        ContactFrictionless = ffi::mjCNSTR_CONTACT_FRICTIONLESS => "frictionless contact",
        ContactPyramidal = ffi::mjCNSTR_CONTACT_PYRAMIDAL => "pyramidal contact",
        ContactElliptic = ffi::mjCNSTR_CONTACT_ELLIPTIC => "elliptic contact",
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn codes_round_trip_and_unknown_codes_are_none() {
        assert_eq!(JointType::from_raw(ffi::mjJNT_HINGE as i32), Some(JointType::Hinge));
        assert_eq!(GeomType::from_raw(ffi::mjGEOM_BOX as i32), Some(GeomType::Box));
        assert_eq!(ConstraintType::from_raw(ffi::mjCNSTR_EQUALITY as i32), Some(ConstraintType::Equality));
        assert_eq!(JointType::from_raw(99), None);
        assert_eq!(Transmission::Joint.to_string(), "joint");
    }
}
