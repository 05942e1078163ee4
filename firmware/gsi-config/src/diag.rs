//! Diagnostics: every problem in a GSI folder is reported with file, line,
//! column and the PROTOCOL.md rule it breaks, the way a compiler would, so a
//! user can jump straight to it from the build output.

use std::fmt;
use std::path::{Path, PathBuf};

/// The PROTOCOL.md rule a diagnostic is about.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Rule {
    /// Settings.xml: clients, convention, device selection.
    G1,
    /// Description.xml: name, network, channel, supervision settings.
    G2,
    /// Configuration.xml: enums, records, fields, properties, flags.
    G3,
    /// Names: RAPID symbols of at most 16 characters.
    G4,
    /// Types: the simple types and their aliases, or a declared enum/record.
    G5,
    /// Quirks of the manual's own example, accepted with a warning.
    G6,
    /// The file is not well-formed XML.
    Xml,
}

impl fmt::Display for Rule {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Rule::G1 => "G1",
            Rule::G2 => "G2",
            Rule::G3 => "G3",
            Rule::G4 => "G4",
            Rule::G5 => "G5",
            Rule::G6 => "G6",
            Rule::Xml => "xml",
        })
    }
}

/// Whether a diagnostic stops the build.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Severity {
    /// A rule is broken: the folder does not load and the build stops.
    Error,
    /// Accepted and printed (a G6 quirk, an ignored element); the load goes on.
    Warning,
}

/// A 1-based line and column (columns count characters, not bytes).
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Default)]
pub struct Pos {
    /// 1-based line.
    pub line: u32,
    /// 1-based column, in characters.
    pub col: u32,
}

/// One finding in one file.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Diagnostic {
    /// Whether it stops the build.
    pub severity: Severity,
    /// The rule it is about; a missing or unreadable file is reported under
    /// the rule of that file (G1, G2 or G3).
    pub rule: Rule,
    /// The file, as the path it was read from.
    pub file: PathBuf,
    /// Where in `file` the problem is.
    pub pos: Pos,
    /// What is wrong, without file, position or rule (`Display` adds them).
    pub message: String,
}

impl Diagnostic {
    /// Whether this is a [`Severity::Error`], which stops the build.
    pub fn is_error(&self) -> bool {
        self.severity == Severity::Error
    }

    /// The file path relative to `base` (falls back to the full path), for
    /// tests and for messages that should not depend on where the tree lives.
    pub fn file_relative_to(&self, base: &Path) -> String {
        self.file
            .strip_prefix(base)
            .unwrap_or(&self.file)
            .to_string_lossy()
            .replace('\\', "/")
    }
}

impl fmt::Display for Diagnostic {
    /// `path:line:col: error[G4]: message`, the format editors and CI
    /// annotators already understand.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let kind = match self.severity {
            Severity::Error => "error",
            Severity::Warning => "warning",
        };
        write!(
            f,
            "{}:{}:{}: {}[{}]: {}",
            self.file.display(),
            self.pos.line,
            self.pos.col,
            kind,
            self.rule,
            self.message
        )
    }
}

/// Collects diagnostics for one file so that checks can keep going after the
/// first problem: a user fixing a configuration wants every error at once.
#[derive(Debug)]
pub struct Sink<'a> {
    file: &'a Path,
    out: &'a mut Vec<Diagnostic>,
}

impl<'a> Sink<'a> {
    /// A sink for the diagnostics of `file`, appended to `out`.
    pub fn new(file: &'a Path, out: &'a mut Vec<Diagnostic>) -> Self {
        Sink { file, out }
    }

    /// The file its diagnostics are about.
    pub fn file(&self) -> &Path {
        self.file
    }

    /// Reports an error at `pos`: the folder will not load.
    pub fn error(&mut self, rule: Rule, pos: Pos, message: impl Into<String>) {
        self.push(Severity::Error, rule, pos, message.into());
    }

    /// Reports a warning at `pos`: printed, the load goes on.
    pub fn warning(&mut self, rule: Rule, pos: Pos, message: impl Into<String>) {
        self.push(Severity::Warning, rule, pos, message.into());
    }

    fn push(&mut self, severity: Severity, rule: Rule, pos: Pos, message: String) {
        self.out.push(Diagnostic {
            severity,
            rule,
            file: self.file.to_path_buf(),
            pos,
            message,
        });
    }
}
