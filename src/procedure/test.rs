//! What a procedure adds to a test's identity: its built-in template.
//! The identity itself ([`Test`], its name and its [`Test::kind`]) is part
//! of the plan file (`src/formats/manifest.rs`), which both the procedures
//! and the measurement readers stand on.

use super::Test;

impl Test {
    /// The built-in template's YAML text (`templates/<test>.yaml`).
    pub fn template_text(self) -> &'static str {
        match self {
            Test::SteppedSquare => super::machining::stepped_square::BUILTIN_TEMPLATE,
            Test::NineSection => super::machining::nine_section::BUILTIN_TEMPLATE,
            Test::ProbeColumns => super::probing::columns::BUILTIN_TEMPLATE,
            Test::ProbeSphere => super::probing::sphere::BUILTIN_TEMPLATE,
        }
    }
}
