//! Generates the message layouts of every test configuration, so one
//! `cargo test` exercises several GSI folders (the firmware itself is built
//! for one). Each becomes a module of `host_tests::layouts`.

use std::path::PathBuf;

/// (module name, GSI folder relative to the workspace root, device).
const LAYOUTS: &[(&str, &str, Option<&str>)] = &[
    ("anydevice", "../shared/rri/examples/GSI", None),
    ("udptest", "../shared/rri/real-world/GSI", Some("UdpTest")),
    ("every_type", "host-tests/gsi/every-type/GSI", None),
    ("several", "host-tests/gsi/several-properties/GSI", None),
    ("fragmented", "host-tests/gsi/fragmented/GSI", None),
];

fn main() {
    let manifest = PathBuf::from(std::env::var("CARGO_MANIFEST_DIR").expect("set by cargo"));
    let workspace = manifest
        .parent()
        .expect("host-tests is inside the workspace");
    let out = PathBuf::from(std::env::var("OUT_DIR").expect("set by cargo"));
    let mut modules = String::new();
    for (module, dir, device) in LAYOUTS {
        let gsi = workspace.join(dir);
        println!("cargo:rerun-if-changed={}", gsi.display());
        let loaded = gsi_config::load(&gsi, *device).unwrap_or_else(|failed| {
            panic!(
                "test configuration {} does not load (is ../shared beside the checkout?):\n{failed}",
                gsi.display()
            )
        });
        for f in &loaded.files {
            println!("cargo:rerun-if-changed={}", f.display());
        }
        let opts = gsi_codegen::Options {
            crate_path: "::rri_firmware".into(),
            ..Default::default()
        };
        let source = gsi_codegen::generate(&loaded.device, &opts)
            .unwrap_or_else(|e| panic!("{}: {e:?}", gsi.display()));
        let file = out.join(format!("{module}.rs"));
        std::fs::write(&file, source).expect("write generated layout");
        modules.push_str(&format!(
            "/// Layout generated from `{dir}`{}.\npub mod {module} {{\n    include!(concat!(env!(\"OUT_DIR\"), \"/{module}.rs\"));\n}}\n",
            device.map(|d| format!(" (device `{d}`)")).unwrap_or_default()
        ));
    }
    std::fs::write(out.join("layouts.rs"), modules).expect("write layouts.rs");
}
