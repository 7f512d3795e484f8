//! How finely the T-shirt is meshed.

use std::fmt;
use std::str::FromStr;

use serde::{Deserialize, Serialize};

use crate::error::{Error, Result};
use crate::math::Real;

/// How finely the T-shirt is meshed.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Resolution {
    /// About 800 vertices: fast tests and CI.
    Coarse,
    /// About 2,500 vertices.
    #[default]
    Default,
    /// About 4,300 vertices, like the paper's mesh (n = 4,281).
    Paper,
}

impl Resolution {
    /// All resolutions, coarsest first.
    pub const ALL: [Resolution; 3] = [Resolution::Coarse, Resolution::Default, Resolution::Paper];

    /// The pattern grid spacing (metres).
    #[must_use]
    pub fn grid_spacing(self) -> Real {
        match self {
            Resolution::Coarse => 0.034,
            Resolution::Default => 0.019,
            Resolution::Paper => 0.0146,
        }
    }

    /// The lowercase name (`coarse`, `default`, `paper`).
    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            Resolution::Coarse => "coarse",
            Resolution::Default => "default",
            Resolution::Paper => "paper",
        }
    }
}

impl fmt::Display for Resolution {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl FromStr for Resolution {
    type Err = Error;

    fn from_str(s: &str) -> Result<Self> {
        Resolution::ALL
            .into_iter()
            .find(|r| r.name().eq_ignore_ascii_case(s.trim()))
            .ok_or_else(|| Error::UnknownName {
                kind: "resolution",
                name: s.trim().to_owned(),
                options: "coarse, default or paper",
            })
    }
}
