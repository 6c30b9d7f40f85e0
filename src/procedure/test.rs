//! Which calibration test: the identity of a test, parsed once from the
//! command line, a manifest or a template's `test:` key, and matched on
//! from then on.

use std::fmt;
use std::str::FromStr;

use serde::{Deserialize, Serialize};

use crate::formats::manifest::TestKind;

/// A calibration test.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Test {
    /// Squares stepped into the top and the sides of a block, each cut at
    /// its own pose, measured on a CMM (Ibaraki & Ota 2014).
    SteppedSquare,
    /// Nine sections of a face cut at nine poses, their heights measured
    /// (Cubas Brizuela & Yeh 2023).
    NineSection,
    /// Square columns probed on the machine at many poses (Ibaraki,
    /// Iritani & Matsushita 2013).
    ProbeColumns,
    /// A calibration sphere probed on the machine at many poses.
    ProbeSphere,
}

impl Test {
    /// Every test, in the order they are offered.
    pub const ALL: [Test; 4] = [
        Test::SteppedSquare,
        Test::NineSection,
        Test::ProbeColumns,
        Test::ProbeSphere,
    ];

    /// The tests that probe on the machine.
    pub const PROBING: [Test; 2] = [Test::ProbeColumns, Test::ProbeSphere];

    /// The name on the command line, in manifests and templates.
    pub const fn as_str(self) -> &'static str {
        match self {
            Test::SteppedSquare => "stepped-square",
            Test::NineSection => "nine-section",
            Test::ProbeColumns => "probe-columns",
            Test::ProbeSphere => "probe-sphere",
        }
    }

    /// A machined piece measured on a CMM, or probing on the machine.
    pub const fn kind(self) -> TestKind {
        match self {
            Test::SteppedSquare | Test::NineSection => TestKind::Machining,
            Test::ProbeColumns | Test::ProbeSphere => TestKind::Probing,
        }
    }

    /// The built-in template's YAML text (`templates/<test>.yaml`).
    pub fn template_text(self) -> &'static str {
        match self {
            Test::SteppedSquare => super::machining::stepped_square::BUILTIN_TEMPLATE,
            Test::NineSection => super::machining::nine_section::BUILTIN_TEMPLATE,
            Test::ProbeColumns => super::probing::columns::BUILTIN_TEMPLATE,
            Test::ProbeSphere => super::probing::sphere::BUILTIN_TEMPLATE,
        }
    }

    /// The names of every test, for messages: `a, b, c or d`.
    pub fn names() -> String {
        let n: Vec<&str> = Test::ALL.iter().map(|t| t.as_str()).collect();
        format!("{} or {}", n[..n.len() - 1].join(", "), n[n.len() - 1])
    }
}

impl fmt::Display for Test {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.as_str())
    }
}

/// A test equals its name (`test == "nine-section"` in a worked example).
impl PartialEq<&str> for Test {
    fn eq(&self, other: &&str) -> bool {
        self.as_str() == *other
    }
}

impl FromStr for Test {
    type Err = String;
    fn from_str(s: &str) -> Result<Test, String> {
        Test::ALL
            .into_iter()
            .find(|t| t.as_str() == s)
            .ok_or_else(|| format!("unknown test `{s}`: expected {}", Test::names()))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_parse_back_and_serialize_as_written() {
        for t in Test::ALL {
            assert_eq!(t.as_str().parse::<Test>(), Ok(t));
            assert_eq!(serde_yaml::to_string(&t).unwrap().trim(), t.as_str());
        }
        assert_eq!(
            "probe".parse::<Test>().unwrap_err(),
            "unknown test `probe`: expected stepped-square, nine-section, probe-columns or probe-sphere"
        );
    }
}
