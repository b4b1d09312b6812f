//! The one name table of each enumerated setting of the engine: the QP solver
//! ([`SolverKind`]), the constraint form ([`ConstraintForm`]) and the rotation coordinates
//! ([`RotationCoordinates`]). Scene files, the command line and code all use these same types
//! and names, so a name accepted in one place is accepted everywhere. (The tree builder's
//! names live with its type, `spheretree::build::BuildMethod`.)

use std::fmt;

use collide::{ConstraintForm, RotationCoordinates};
use qp::SolverKind;

/// A name that is not one of a setting's values. Displays as one line:
/// `unknown solver `newton`; expected one of: dual, pqp, active-set, pqp-parallel`.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct UnknownSetting {
    /// What kind of setting (`solver`, `constraint form`, ...).
    pub what: &'static str,
    /// The name given.
    pub given: String,
    /// The accepted names, comma separated.
    pub expected: String,
}

impl fmt::Display for UnknownSetting {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "unknown {} `{}`; expected one of: {}",
            self.what, self.given, self.expected
        )
    }
}

impl std::error::Error for UnknownSetting {}

/// An enumerated setting with one name per value (kebab-case, as written in scene files and on
/// the command line).
pub trait Setting: Sized + Copy + PartialEq + 'static {
    /// What the setting is, for messages (`solver`).
    const WHAT: &'static str;
    /// Every value, in the order the names are listed in messages.
    const ALL: &'static [Self];
    /// Other spellings accepted on input (after lower-casing and trimming).
    const ALIASES: &'static [(&'static str, Self)] = &[];

    /// The name of the value (`dual`, `squared`, `rotation-vector`, `tight`).
    fn setting_name(self) -> &'static str;

    /// The accepted names, comma separated.
    fn expected() -> String {
        Self::ALL
            .iter()
            .map(|v| v.setting_name())
            .collect::<Vec<_>>()
            .join(", ")
    }

    /// Parses a name (case and surrounding spaces ignored, aliases accepted).
    fn parse_setting(text: &str) -> Result<Self, UnknownSetting> {
        let key = text.trim().to_ascii_lowercase();
        Self::ALL
            .iter()
            .copied()
            .find(|v| v.setting_name() == key)
            .or_else(|| {
                Self::ALIASES
                    .iter()
                    .find(|(alias, _)| *alias == key)
                    .map(|(_, v)| *v)
            })
            .ok_or_else(|| UnknownSetting {
                what: Self::WHAT,
                given: text.to_string(),
                expected: Self::expected(),
            })
    }
}

impl Setting for SolverKind {
    const WHAT: &'static str = "solver";
    const ALL: &'static [Self] = &[
        SolverKind::Dual,
        SolverKind::Pqp,
        SolverKind::ActiveSet,
        SolverKind::PqpParallel,
    ];
    const ALIASES: &'static [(&'static str, Self)] = &[
        ("activeset", SolverKind::ActiveSet),
        ("active_set", SolverKind::ActiveSet),
        ("pqp_parallel", SolverKind::PqpParallel),
    ];
    fn setting_name(self) -> &'static str {
        self.name()
    }
}

impl Setting for ConstraintForm {
    const WHAT: &'static str = "constraint form";
    const ALL: &'static [Self] = &[ConstraintForm::Distance, ConstraintForm::Squared];
    fn setting_name(self) -> &'static str {
        match self {
            ConstraintForm::Distance => "distance",
            ConstraintForm::Squared => "squared",
        }
    }
}

impl Setting for RotationCoordinates {
    const WHAT: &'static str = "rotation coordinates";
    const ALL: &'static [Self] = &[
        RotationCoordinates::RotationVector,
        RotationCoordinates::Euler,
    ];
    const ALIASES: &'static [(&'static str, Self)] =
        &[("rotvec", RotationCoordinates::RotationVector)];
    fn setting_name(self) -> &'static str {
        match self {
            RotationCoordinates::RotationVector => "rotation-vector",
            RotationCoordinates::Euler => "euler",
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn round_trip<S: Setting + fmt::Debug>() {
        for &v in S::ALL {
            assert_eq!(S::parse_setting(v.setting_name()).unwrap(), v);
            let shouted = format!("  {}  ", v.setting_name().to_ascii_uppercase());
            assert_eq!(S::parse_setting(&shouted).unwrap(), v);
        }
        let e = S::parse_setting("newton").unwrap_err().to_string();
        assert!(e.contains(S::WHAT) && e.contains(&S::expected()), "{e}");
    }

    #[test]
    fn every_name_parses_back_and_unknown_names_list_the_choices() {
        round_trip::<SolverKind>();
        round_trip::<ConstraintForm>();
        round_trip::<RotationCoordinates>();
        assert_eq!(
            SolverKind::parse_setting("active_set").unwrap(),
            SolverKind::ActiveSet
        );
        assert_eq!(
            SolverKind::parse_setting("newton").unwrap_err().to_string(),
            "unknown solver `newton`; expected one of: dual, pqp, active-set, pqp-parallel"
        );
    }
}
