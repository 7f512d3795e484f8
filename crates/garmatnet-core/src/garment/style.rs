//! Which T-shirt cut a [`crate::Garment`] is: the fitted shirt (the default, the shipped
//! model's) or the boxy shirt the models shipped up to version 0.3 were trained on.

use std::fmt;
use std::str::FromStr;

use serde::{Deserialize, Serialize};

use crate::error::{Error, Result};

/// The cut of the procedural T-shirt.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum GarmentStyle {
    /// A regular-fit T-shirt: crew neckline, shoulder seams sloping onto the shoulders,
    /// short sleeves cut at the arm's angle, about 10 cm of chest ease, dressed in
    /// [`crate::Pose::a_pose`].
    #[default]
    Fitted,
    /// The first template: a T-shaped box with a wide rectangular neck cut-out, dressed in
    /// the T-pose (the models shipped up to version 0.3, revision 2's the last, were
    /// trained on it).
    Boxy,
}

impl GarmentStyle {
    /// All styles, the default first.
    pub const ALL: [GarmentStyle; 2] = [GarmentStyle::Fitted, GarmentStyle::Boxy];

    /// The stable lowercase name (`fitted`, `boxy`), as files and template hashes record it.
    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            GarmentStyle::Fitted => "fitted",
            GarmentStyle::Boxy => "boxy",
        }
    }
}

impl fmt::Display for GarmentStyle {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl FromStr for GarmentStyle {
    type Err = Error;

    fn from_str(s: &str) -> Result<Self> {
        GarmentStyle::ALL
            .into_iter()
            .find(|g| g.name().eq_ignore_ascii_case(s.trim()))
            .ok_or_else(|| Error::UnknownName {
                kind: "garment style",
                name: s.trim().to_owned(),
                options: "fitted or boxy",
            })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn style_parses_and_prints() {
        for g in GarmentStyle::ALL {
            assert_eq!(g.to_string().parse::<GarmentStyle>().unwrap(), g);
            let json = serde_json::to_string(&g).unwrap();
            assert_eq!(json, format!("\"{}\"", g.name()));
            assert_eq!(serde_json::from_str::<GarmentStyle>(&json).unwrap(), g);
        }
        assert!("slim".parse::<GarmentStyle>().is_err());
        assert_eq!(GarmentStyle::default(), GarmentStyle::Fitted);
    }
}
