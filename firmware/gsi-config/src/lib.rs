//! # gsi-config: the ABB RRI GSI folder, parsed and validated
//!
//! A robot controller keeps its Robot Reference Interface configuration in
//! `HOME/GSI`: `Settings.xml` lists the devices (CDP clients), and each
//! device's folder holds `Description.xml` (network, channel, supervision)
//! and `Configuration.xml` (enums, records, properties). This crate reads
//! such a folder with `xmlparser`, checks every rule G1–G6 of the team's
//! PROTOCOL.md, and returns one [`Device`] model.
//!
//! It is the only parser of these files in the project: the firmware's build
//! script generates its message layouts from the model, and the host tools
//! (robot simulator) read the same model at run time.
//!
//! Every problem is a [`Diagnostic`] with file, line, column and rule, and all
//! of them are reported, not only the first:
//!
//! ```text
//! GSI/AnyDevice/Configuration.xml:14:7: error[G4]: field name "…" has 17 characters (max 16)
//! ```
//!
//! ```no_run
//! let loaded = gsi_config::load("GSI".as_ref(), Some("AnyDevice"))
//!     .map_err(|failed| failed.to_string())?;
//! println!("{} listens on port {}", loaded.device.name, loaded.device.channel.port);
//! # Ok::<(), String>(())
//! ```

#![warn(missing_docs)]
pub mod configuration;
pub mod description;
mod diag;
mod model;
pub mod names;
mod selection;
pub mod settings;
pub mod xml;

pub use diag::{Diagnostic, Pos, Rule, Severity, Sink};
pub use model::*;
pub use selection::{setting, Selection, BUILD_SETTINGS, DEFAULT_GSI_DIR};

use std::fmt;
use std::path::{Path, PathBuf};

/// A folder that did not load: every diagnostic (errors and warnings, in
/// file order) and the files that were looked at, so a build script can still
/// ask to be re-run when one of them changes.
#[derive(Clone, Debug)]
pub struct Failed {
    /// Every error and warning, in the order the files were read; at least
    /// one is an error.
    pub diagnostics: Vec<Diagnostic>,
    /// The files looked at, missing ones included, for `rerun-if-changed`.
    pub files: Vec<PathBuf>,
}

impl Failed {
    /// The diagnostics with [`Severity::Error`], the ones that stopped the load.
    pub fn errors(&self) -> impl Iterator<Item = &Diagnostic> {
        self.diagnostics.iter().filter(|d| d.is_error())
    }
}

impl fmt::Display for Failed {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        for d in &self.diagnostics {
            writeln!(f, "{d}")?;
        }
        let n = self.errors().count();
        write!(
            f,
            "{n} error{} in the GSI configuration",
            if n == 1 { "" } else { "s" }
        )
    }
}

impl std::error::Error for Failed {}

/// Reads one file and parses it into an element tree; `None` after an
/// error (reported) when the file is missing or not XML.
fn with_file<R>(
    path: &Path,
    missing_rule: Rule,
    out: &mut Vec<Diagnostic>,
    files: &mut Vec<PathBuf>,
    f: impl FnOnce(&xml::Element<'_>, &mut Sink<'_>) -> R,
) -> Option<R> {
    files.push(path.to_path_buf());
    let mut sink = Sink::new(path, out);
    let text = match std::fs::read_to_string(path) {
        Ok(t) => t,
        Err(e) => {
            sink.error(
                missing_rule,
                Pos { line: 1, col: 1 },
                format!("cannot read the file: {e}"),
            );
            return None;
        }
    };
    let root = xml::parse(&text, &mut sink)?;
    Some(f(&root, &mut sink))
}

/// Loads the device `device` (or the only CDP client, when `None`) from the
/// GSI folder `gsi_dir`, checking rules G1–G6.
pub fn load(gsi_dir: &Path, device: Option<&str>) -> Result<Loaded, Failed> {
    let mut diags = Vec::new();
    let mut files = Vec::new();
    let settings_path = gsi_dir.join("Settings.xml");

    let chosen = with_file(
        &settings_path,
        Rule::G1,
        &mut diags,
        &mut files,
        |root, sink| {
            let settings = settings::read(root, sink);
            settings::choose(&settings, device, sink).map(|c| c.name.clone())
        },
    )
    .flatten();
    // Without Settings.xml the named device's folder can still be checked.
    let client = chosen.or_else(|| {
        (!settings_path.exists())
            .then(|| device.map(str::to_string))
            .flatten()
    });

    let mut result = None;
    if let Some(client) = client {
        let dir = gsi_dir.join(&client);
        let description = with_file(
            &dir.join("Description.xml"),
            Rule::G2,
            &mut diags,
            &mut files,
            |root, sink| description::read(root, &client, sink),
        );
        let config_path = dir.join("Configuration.xml");
        let config = with_file(
            &config_path,
            Rule::G3,
            &mut diags,
            &mut files,
            configuration::read,
        );
        if let (Some(d), Some(c)) = (description, config) {
            if let (Some(name), Some(network), Some(channel), Some(supervision)) =
                (d.name, d.network, d.channel, d.supervision)
            {
                result = Some(Device {
                    name,
                    device_type: d.device_type,
                    class: d.class,
                    network,
                    channel,
                    supervision,
                    enums: c.enums,
                    records: c.records,
                    properties: c.properties,
                    configuration_file: config_path,
                });
            }
        }
    }

    match result {
        Some(device) if !diags.iter().any(Diagnostic::is_error) => Ok(Loaded {
            device,
            files,
            warnings: diags,
        }),
        _ => {
            if !diags.iter().any(Diagnostic::is_error) {
                // Defensive: a missing part always reports an error above.
                diags.push(Diagnostic {
                    severity: Severity::Error,
                    rule: Rule::G2,
                    file: gsi_dir.to_path_buf(),
                    pos: Pos { line: 1, col: 1 },
                    message: "the device could not be loaded".into(),
                });
            }
            Err(Failed {
                diagnostics: diags,
                files,
            })
        }
    }
}
