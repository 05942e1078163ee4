//! Golden test of the generated layout for the manual's example (the
//! firmware's default configuration): every change to generated code shows
//! up here for review. Regenerate with `UPDATE_GOLDEN=1 cargo test -p
//! host-tests --test golden` and read the diff before committing it.

use host_tests::workspace;
use std::path::Path;
use std::process::Command;

fn generate_default() -> String {
    let dir = workspace().join("firmware/gsi/GSI");
    let loaded = gsi_config::load(&dir, None).unwrap_or_else(|f| panic!("{f}"));
    gsi_codegen::generate(&loaded.device, &gsi_codegen::Options::default())
        .unwrap_or_else(|e| panic!("{e:?}"))
}

#[test]
fn generated_layout_of_the_manual_example_matches_the_golden_file() {
    let golden = workspace().join("host-tests/golden/anydevice_layout.rs");
    let generated = generate_default();
    if std::env::var_os("UPDATE_GOLDEN").is_some() {
        std::fs::write(&golden, &generated).expect("write golden");
    }
    let expected = std::fs::read_to_string(&golden).expect("golden file exists");
    if expected != generated {
        let first = expected
            .lines()
            .zip(generated.lines())
            .position(|(a, b)| a != b)
            .unwrap_or(expected.lines().count().min(generated.lines().count()));
        panic!(
            "generated layout differs from {} at line {}:\n  golden:    {:?}\n  generated: {:?}\n(UPDATE_GOLDEN=1 to accept, after reviewing)",
            golden.display(),
            first + 1,
            expected.lines().nth(first),
            generated.lines().nth(first)
        );
    }
}

fn rustfmt_check(file: &Path) {
    let out = Command::new(std::env::var("RUSTFMT").unwrap_or_else(|_| "rustfmt".into()))
        .args(["--check", "--edition", "2021"])
        .arg(file)
        .output()
        .expect("rustfmt runs (rust-toolchain.toml installs it)");
    assert!(
        out.status.success(),
        "{} is not rustfmt-clean:\n{}",
        file.display(),
        String::from_utf8_lossy(&out.stdout)
    );
}

#[test]
fn generated_layouts_are_formatted_as_rustfmt_would() {
    rustfmt_check(&workspace().join("host-tests/golden/anydevice_layout.rs"));
    for module in ["anydevice", "udptest", "every_type", "several"] {
        rustfmt_check(&Path::new(env!("OUT_DIR")).join(format!("{module}.rs")));
    }
}

#[test]
fn firmware_layout_is_the_generated_one() {
    // The firmware library was built from the same default configuration:
    // its constants are the golden file's.
    use rri_firmware::layout as fw;
    use rri_firmware::schema::Message;
    let golden = generate_default();
    assert!(golden.contains(&format!(
        "pub const MAX_RECEIVE_LEN: usize = {};",
        fw::MAX_RECEIVE_LEN
    )));
    assert!(golden.contains(&format!(
        "pub const MAX_SEND_LEN: usize = {};",
        fw::MAX_SEND_LEN
    )));
    assert_eq!(fw::RobDataMessage::WIRE_NAME, "RobData");
    assert_eq!(fw::SensDataMessage::MAX_ENCODED_LEN, fw::MAX_SEND_LEN);
}
