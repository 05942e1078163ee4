//! The GSI configuration compiler against the manual's example, the
//! real-world folder and broken configurations (rules G1–G6 of
//! PROTOCOL.md). Every broken case asserts the exact rule, file, line and
//! column, and that the position points at the offending text.

use gsi_config::{load, Diagnostic, Rule, Severity};
use host_tests::{shared_rri, workspace};
use std::fs;
use std::path::{Path, PathBuf};

/// The text at a 1-based line/column of a file, for checking that a
/// reported position points at the right thing.
fn text_at(file: &Path, line: u32, col: u32) -> String {
    let text = fs::read_to_string(file).unwrap_or_default();
    let l = text.lines().nth(line as usize - 1).unwrap_or("");
    l.chars().skip(col as usize - 1).collect()
}

/// A copy of the manual's AnyDevice folder (the firmware's default) in a
/// fresh temporary directory, with `edits` applied: (file, from, to).
fn broken(case: &str, edits: &[(&str, &str, &str)]) -> PathBuf {
    let src = workspace().join("firmware/gsi/GSI");
    let dir = std::env::temp_dir().join(format!("rri-gsi-{}-{case}", std::process::id()));
    let _ = fs::remove_dir_all(&dir);
    fs::create_dir_all(dir.join("AnyDevice")).expect("mkdir");
    for f in [
        "Settings.xml",
        "AnyDevice/Description.xml",
        "AnyDevice/Configuration.xml",
    ] {
        fs::copy(src.join(f), dir.join(f)).expect("copy");
    }
    for (file, from, to) in edits {
        let path = dir.join(file);
        let text = fs::read_to_string(&path).expect("read");
        assert!(text.contains(from), "{case}: `{from}` not in {file}");
        fs::write(&path, text.replacen(from, to, 1)).expect("write");
    }
    dir
}

/// One expected error: rule, file relative to the GSI folder, line, column,
/// and what the text at that position starts with.
type Expect = (Rule, &'static str, u32, u32, &'static str);

fn check_errors(
    case: &str,
    dir: &Path,
    device: Option<&str>,
    expected: &[Expect],
) -> Vec<Diagnostic> {
    let failed = match load(dir, device) {
        Ok(_) => panic!("{case}: loaded, but errors were expected"),
        Err(f) => f,
    };
    let errors: Vec<_> = failed.errors().cloned().collect();
    let got: Vec<_> = errors
        .iter()
        .map(|d| (d.rule, d.file_relative_to(dir), d.pos.line, d.pos.col))
        .collect();
    let want: Vec<_> = expected
        .iter()
        .map(|(r, f, l, c, _)| (*r, f.to_string(), *l, *c))
        .collect();
    assert_eq!(got, want, "{case}: {failed}");
    for (d, (_, _, l, c, snippet)) in errors.iter().zip(expected) {
        let at = text_at(&d.file, *l, *c);
        assert!(
            at.starts_with(snippet),
            "{case}: {d}\n  points at `{at}`, expected `{snippet}`"
        );
    }
    let _ = fs::remove_dir_all(dir);
    errors
}

#[test]
fn g6_manual_example_builds_with_its_two_warnings() {
    let dir = shared_rri().join("examples/GSI");
    let loaded = load(&dir, None).unwrap_or_else(|f| panic!("{f}"));
    let w: Vec<_> = loaded
        .warnings
        .iter()
        .map(|d| {
            (
                d.severity,
                d.rule,
                d.file_relative_to(&dir),
                d.pos.line,
                d.pos.col,
            )
        })
        .collect();
    assert_eq!(
        w,
        vec![
            (
                Severity::Warning,
                Rule::G6,
                "AnyDevice/Configuration.xml".into(),
                2,
                1
            ),
            (
                Severity::Warning,
                Rule::G6,
                "AnyDevice/Configuration.xml".into(),
                15,
                7
            ),
        ]
    );
    assert!(loaded.warnings[1].message.contains("Alias=\"RobMode\" />"));
    let d = &loaded.device;
    assert_eq!(d.name, "AnyDevice");
    assert_eq!(d.network.address, "10.49.65.74");
    assert_eq!(d.network.port, gsi_config::ControllerPort::Service);
    assert_eq!(d.channel.protocol, gsi_config::Protocol::Udp);
    assert_eq!(d.channel.port, 3002);
    assert_eq!(
        d.supervision,
        gsi_config::Supervision {
            timeout_ms: 2000,
            max_lost: 30,
            dry_run: false
        }
    );
    let robot = &d.records[0];
    assert_eq!(robot.fields.len(), 8, "the stray Alias line adds no field");
    assert_eq!(robot.fields[0].wire(), "RobMode");
    assert_eq!(robot.fields[7].size, Some(18));
    // G3 directions.
    let dirs: Vec<_> = d
        .properties
        .iter()
        .map(|p| {
            (
                p.wire(),
                p.direction.robot_sends(),
                p.direction.device_sends(),
            )
        })
        .collect();
    assert_eq!(
        dirs,
        vec![("RobData", true, false), ("SensData", false, true)]
    );
}

#[test]
fn the_firmware_default_is_the_manual_example_verbatim() {
    for f in [
        "Settings.xml",
        "AnyDevice/Description.xml",
        "AnyDevice/Configuration.xml",
    ] {
        let ours = fs::read(workspace().join("firmware/gsi/GSI").join(f)).expect("ours");
        let manual = fs::read(shared_rri().join("examples/GSI").join(f)).expect("manual");
        assert_eq!(ours, manual, "{f} differs from ../shared/rri/examples/GSI");
    }
}

#[test]
fn real_world_udptest_builds() {
    let dir = shared_rri().join("real-world/GSI");
    let loaded = load(&dir, Some("UdpTest")).unwrap_or_else(|f| panic!("{f}"));
    assert!(loaded.warnings.is_empty(), "{:?}", loaded.warnings);
    let d = &loaded.device;
    assert_eq!(
        d.network.port,
        gsi_config::ControllerPort::Lan,
        "Port omitted = Lan (G2)"
    );
    assert_eq!(d.channel.port, 2999);
    assert!(d.supervision.dry_run);
    assert_eq!(d.supervision.max_lost, 10000);
    let wires: Vec<_> = d
        .properties
        .iter()
        .map(|p| (p.name.as_str(), p.wire()))
        .collect();
    assert_eq!(
        wires,
        vec![("RsRobData", "RobData"), ("RsSensData", "SensData")]
    );
    assert_eq!(d.records[0].fields[7].size, Some(20));
}

#[test]
fn g1_real_world_without_a_device_lists_its_three_clients() {
    let dir = shared_rri().join("real-world/GSI");
    let failed = load(&dir, None).expect_err("three clients, none chosen");
    let errors: Vec<_> = failed.errors().collect();
    assert_eq!(errors.len(), 1, "{failed}");
    let e = errors[0];
    assert_eq!((e.rule, e.pos.line, e.pos.col), (Rule::G1, 5, 2));
    assert_eq!(e.file_relative_to(&dir), "Settings.xml");
    for client in ["NACMaster", "NACMasterUdp", "UdpTest"] {
        assert!(e.message.contains(client), "{}", e.message);
    }
    assert!(e.message.contains("RRI_DEVICE"), "{}", e.message);
}

const CFG: &str = "AnyDevice/Configuration.xml";
const DESC: &str = "AnyDevice/Description.xml";
const SET: &str = "Settings.xml";

#[test]
fn g4_field_name_too_long() {
    let dir = broken(
        "g4-long",
        &[(CFG, "Name=\"FeedbackTime\"", "Name=\"FeedbackTimeStamp\"")],
    );
    let e = check_errors(
        "g4-long",
        &dir,
        None,
        &[(Rule::G4, CFG, 16, 14, "Name=\"FeedbackTimeStamp\"")],
    );
    assert_eq!(
        e[0].message,
        "field name \"FeedbackTimeStamp\" has 17 characters (max 16)"
    );
}

#[test]
fn g4_member_name_starts_with_a_digit() {
    let dir = broken("g4-digit", &[(CFG, "Name=\"FullSpeed\"", "Name=\"2Fast\"")]);
    check_errors(
        "g4-digit",
        &dir,
        None,
        &[(Rule::G4, CFG, 8, 15, "Name=\"2Fast\"")],
    );
}

#[test]
fn g4_device_name_with_a_space() {
    let dir = broken(
        "g4-space",
        &[(SET, "Name=\"AnyDevice\"", "Name=\"Any Device\"")],
    );
    check_errors(
        "g4-space",
        &dir,
        None,
        &[
            (Rule::G4, SET, 5, 30, "Name=\"Any Device\""),
            (Rule::G1, SET, 4, 3, "<Clients>"),
        ],
    );
}

#[test]
fn g5_unknown_type() {
    let dir = broken(
        "g5-type",
        &[(
            CFG,
            "Type=\"Pose\" Link=\"Intern\"\n        Alias=\"P_act\"",
            "Type=\"Posture\" Link=\"Intern\"\n        Alias=\"P_act\"",
        )],
    );
    let e = check_errors(
        "g5-type",
        &dir,
        None,
        &[(Rule::G5, CFG, 18, 34, "Type=\"Posture\"")],
    );
    assert!(e[0].message.contains("unknown type \"Posture\""));
}

#[test]
fn g5_type_named_like_a_simple_type() {
    let dir = broken(
        "g5-shadow",
        &[(
            CFG,
            "<Record Name=\"SensorData\">",
            "<Record Name=\"pose\">",
        )],
    );
    // The record is not declared, so the property that uses it fails too.
    check_errors(
        "g5-shadow",
        &dir,
        None,
        &[
            (Rule::G5, CFG, 31, 13, "Name=\"pose\""),
            (Rule::G5, CFG, 39, 31, "Type=\"SensorData\""),
        ],
    );
}

#[test]
fn g3_size_on_a_frame() {
    let dir = broken(
        "g3-size-frame",
        &[(
            CFG,
            "Type=\"Pose\" Link=\"Intern\"\n        Alias=\"P_act\"",
            "Type=\"Pose\" Size=\"2\" Link=\"Intern\"\n        Alias=\"P_act\"",
        )],
    );
    check_errors(
        "g3-size-frame",
        &dir,
        None,
        &[(Rule::G3, CFG, 18, 46, "Size=\"2\"")],
    );
}

#[test]
fn g3_size_zero() {
    let dir = broken("g3-size-zero", &[(CFG, "Size=\"18\"", "Size=\"0\"")]);
    check_errors(
        "g3-size-zero",
        &dir,
        None,
        &[(Rule::G3, CFG, 28, 48, "Size=\"0\"")],
    );
}

#[test]
fn g3_flag_not_in_the_list() {
    let dir = broken("g3-flag", &[(CFG, "Flag=\"WriteOnly\"", "Flag=\"Write\"")]);
    check_errors(
        "g3-flag",
        &dir,
        None,
        &[(Rule::G3, CFG, 38, 47, "Flag=\"Write\"")],
    );
}

#[test]
fn g3_duplicate_field_names() {
    let dir = broken(
        "g3-dup-field",
        &[(
            CFG,
            "Name=\"ErrorString\" Type=\"String\" Alias=\"EStr\"",
            "Name=\"ApplicationData\" Type=\"String\" Alias=\"EStr\"",
        )],
    );
    check_errors(
        "g3-dup-field",
        &dir,
        None,
        &[(Rule::G3, CFG, 33, 7, "<Field Name=\"ApplicationData\"")],
    );
}

#[test]
fn g3_nested_record() {
    let dir = broken(
        "g3-nested",
        &[(
            CFG,
            "Name=\"ErrorString\" Type=\"String\"",
            "Name=\"ErrorString\" Type=\"RobotData\"",
        )],
    );
    check_errors(
        "g3-nested",
        &dir,
        None,
        &[(Rule::G3, CFG, 32, 33, "Type=\"RobotData\"")],
    );
}

#[test]
fn g3_two_properties_on_one_wire_name() {
    let dir = broken(
        "g3-wire",
        &[(
            CFG,
            "Flag=\"ReadOnly\"/>",
            "Flag=\"ReadOnly\" Alias=\"RobData\"/>",
        )],
    );
    check_errors(
        "g3-wire",
        &dir,
        None,
        &[(Rule::G3, CFG, 39, 5, "<Property Name=\"SensData\"")],
    );
}

#[test]
fn g3_link_other_than_intern() {
    let dir = broken(
        "g3-link",
        &[(
            CFG,
            "<Enum Name=\"OperationMode\" Link=\"Intern\">",
            "<Enum Name=\"OperationMode\" Link=\"Extern\">",
        )],
    );
    check_errors(
        "g3-link",
        &dir,
        None,
        &[(Rule::G3, CFG, 5, 32, "Link=\"Extern\"")],
    );
}

#[test]
fn g3_unknown_element_in_a_record() {
    let dir = broken(
        "g3-feild",
        &[(
            CFG,
            "<Field Name=\"ErrorString\"",
            "<Feild Name=\"ErrorString\"",
        )],
    );
    check_errors("g3-feild", &dir, None, &[(Rule::G3, CFG, 32, 7, "<Feild")]);
}

#[test]
fn g3_alias_that_cannot_be_an_element_name() {
    let dir = broken("g3-alias", &[(CFG, "Alias=\"EStr\"", "Alias=\"E Str\"")]);
    check_errors(
        "g3-alias",
        &dir,
        None,
        &[(Rule::G3, CFG, 32, 47, "Alias=\"E Str\"")],
    );
}

#[test]
fn g2_name_does_not_match_settings() {
    let dir = broken(
        "g2-name",
        &[(DESC, "<Name>AnyDevice</Name>", "<Name>OtherDevice</Name>")],
    );
    check_errors(
        "g2-name",
        &dir,
        None,
        &[(Rule::G2, DESC, 3, 9, "OtherDevice")],
    );
}

#[test]
fn g2_protocol_not_udp_tcp_or_hpudp() {
    let dir = broken(
        "g2-proto",
        &[(DESC, "Protocol=\"Udp\"", "Protocol=\"Sctp\"")],
    );
    check_errors(
        "g2-proto",
        &dir,
        None,
        &[(Rule::G2, DESC, 8, 28, "Protocol=\"Sctp\"")],
    );
}

#[test]
fn g2_channel_port_out_of_range() {
    let dir = broken("g2-port", &[(DESC, "Port=\"3002\"", "Port=\"70000\"")]);
    check_errors(
        "g2-port",
        &dir,
        None,
        &[(Rule::G2, DESC, 8, 43, "Port=\"70000\"")],
    );
}

#[test]
fn g2_timeout_not_a_multiple_of_4() {
    let dir = broken(
        "g2-timeout",
        &[(DESC, "<TimeOut>2000</TimeOut>", "<TimeOut>2001</TimeOut>")],
    );
    check_errors(
        "g2-timeout",
        &dir,
        None,
        &[(Rule::G2, DESC, 11, 14, "2001")],
    );
}

#[test]
fn g2_dry_run_not_a_bool() {
    let dir = broken(
        "g2-dryrun",
        &[(DESC, "<DryRun>false</DryRun>", "<DryRun>maybe</DryRun>")],
    );
    check_errors(
        "g2-dryrun",
        &dir,
        None,
        &[(Rule::G2, DESC, 13, 13, "maybe")],
    );
}

#[test]
fn g2_controller_port_unknown() {
    let dir = broken(
        "g2-ctrl-port",
        &[(DESC, "Port=\"Service\"", "Port=\"Wifi\"")],
    );
    check_errors(
        "g2-ctrl-port",
        &dir,
        None,
        &[(Rule::G2, DESC, 7, 34, "Port=\"Wifi\"")],
    );
}

#[test]
fn g2_settings_missing() {
    let dir = broken("g2-no-settings", &[(DESC, "  <Settings>\n    <TimeOut>2000</TimeOut>\n    <MaxLost>30</MaxLost>\n    <DryRun>false</DryRun>\n  </Settings>\n", "")]);
    check_errors(
        "g2-no-settings",
        &dir,
        None,
        &[(Rule::G2, DESC, 2, 1, "<Description>")],
    );
}

#[test]
fn g1_convention_not_cdp() {
    let dir = broken(
        "g1-conv",
        &[(SET, "Convention=\"CDP\"", "Convention=\"XYZ\"")],
    );
    check_errors(
        "g1-conv",
        &dir,
        None,
        &[(Rule::G1, SET, 5, 13, "Convention=\"XYZ\"")],
    );
}

#[test]
fn g1_device_not_in_settings() {
    let dir = broken("g1-device", &[]);
    let e = check_errors(
        "g1-device",
        &dir,
        Some("Camera"),
        &[(Rule::G1, SET, 4, 3, "<Clients>")],
    );
    assert!(
        e[0].message.contains("clients: AnyDevice"),
        "{}",
        e[0].message
    );
}

#[test]
fn xml_not_well_formed() {
    let dir = broken(
        "xml",
        &[(
            DESC,
            "<Type>IntelligentCamera</Type>",
            "<Type>IntelligentCamera</Typo>",
        )],
    );
    check_errors("xml", &dir, None, &[(Rule::Xml, DESC, 5, 26, "</Typo>")]);
}

#[test]
fn io_missing_configuration() {
    let dir = broken("io", &[]);
    fs::remove_file(dir.join(CFG)).expect("rm");
    check_errors("io", &dir, None, &[(Rule::G3, CFG, 1, 1, "")]);
}

#[test]
fn every_error_of_a_build_is_reported_across_files() {
    let dir = broken(
        "many",
        &[
            (DESC, "Protocol=\"Udp\"", "Protocol=\"Sctp\""),
            (DESC, "<MaxLost>30</MaxLost>", "<MaxLost>-1</MaxLost>"),
            (CFG, "Name=\"FeedbackTime\"", "Name=\"FeedbackTimeStamp\""),
            (CFG, "Flag=\"ReadOnly\"", "Flag=\"Sometimes\""),
        ],
    );
    check_errors(
        "many",
        &dir,
        None,
        &[
            (Rule::G2, DESC, 8, 28, "Protocol=\"Sctp\""),
            (Rule::G2, DESC, 12, 14, "-1"),
            (Rule::G4, CFG, 16, 14, "Name=\"FeedbackTimeStamp\""),
            (Rule::G3, CFG, 39, 49, "Flag=\"Sometimes\""),
        ],
    );
}

#[test]
fn unknown_attributes_are_accepted() {
    // Real controllers write attributes the manual does not list (`Path`).
    let dir = broken(
        "unknown-attr",
        &[(
            SET,
            "Name=\"AnyDevice\"",
            "Name=\"AnyDevice\" Path=\"GSI/AnyDevice\"",
        )],
    );
    let loaded = load(&dir, None).unwrap_or_else(|f| panic!("{f}"));
    assert_eq!(loaded.device.name, "AnyDevice");
    let _ = fs::remove_dir_all(&dir);
}

#[test]
fn type_names_are_case_insensitive_with_aliases() {
    let dir = shared_rri().join("examples/GSI");
    let d = load(&dir, None).expect("loads").device;
    use gsi_config::{SimpleType, TypeRef};
    let types: Vec<_> = d.records[0].fields.iter().map(|f| f.ty).collect();
    assert_eq!(types[1], TypeRef::Simple(SimpleType::Time), "Time");
    assert_eq!(types[2], TypeRef::Simple(SimpleType::Frame), "Pose = frame");
    assert_eq!(
        types[3],
        TypeRef::Simple(SimpleType::Joints),
        "Joint = joints"
    );
    assert_eq!(types[7], TypeRef::Simple(SimpleType::Real), "Num = real");
    assert_eq!(types[0], TypeRef::Enum(0));
}

fn every_type() -> gsi_config::Device {
    let dir = host_tests::workspace().join("host-tests/gsi/every-type/GSI");
    gsi_config::load(&dir, None)
        .unwrap_or_else(|f| panic!("{f}"))
        .device
}

#[test]
fn m11_rri_reply_names_a_property_the_device_sends() {
    let d = every_type();
    // Name or Alias, any case; the position among RsSensData, Shared,
    // Speed, Offsets.
    assert_eq!(
        gsi_codegen::device_property(&d, "RRI_REPLY", "Shared"),
        Ok(1)
    );
    assert_eq!(
        gsi_codegen::device_property(&d, "RRI_REPLY", "sensdata"),
        Ok(0)
    );
    assert_eq!(
        gsi_codegen::device_property(&d, "RRI_REPLY", "OFFSETS"),
        Ok(3)
    );
    let choices = "choose one the device sends: RsSensData, Shared, Speed, Offsets";
    let e = gsi_codegen::device_property(&d, "RRI_REPLY", "RsRobData").unwrap_err();
    assert_eq!(
        e,
        format!("RRI_REPLY=RsRobData: property \"RsRobData\" is Flag=\"WriteOnly\": the device never sends it; {choices}")
    );
    let e = gsi_codegen::device_property(&d, "RRI_REPLY", "Unused").unwrap_err();
    assert!(e.contains("Flag=\"None\"") && e.contains(choices), "{e}");
    let e = gsi_codegen::device_property(&d, "RRI_REPLY", "Nope").unwrap_err();
    assert_eq!(
        e,
        format!("RRI_REPLY=Nope: no property \"Nope\" in the configuration; {choices}")
    );
}

#[test]
fn m11_rri_periodic_lists_name_period_pairs() {
    let d = every_type();
    assert_eq!(
        gsi_codegen::periodic(&d, "Offsets=32, Speed=64", 0),
        Ok(vec![(3, 32), (2, 64)])
    );
    assert_eq!(gsi_codegen::periodic(&d, "", 0), Ok(vec![]));
    for (text, why) in [
        ("Offsets", "is not Name=MS"),
        ("Offsets=30", "positive multiple of 4 ms"),
        ("Offsets=0", "positive multiple of 4 ms"),
        ("RsSensData=8", "is the reply property"),
        ("Offsets=8,offsets=16", "listed twice"),
        ("RsRobData=8", "the device never sends it"),
    ] {
        let e = gsi_codegen::periodic(&d, text, 0).unwrap_err();
        assert!(e.contains(why), "{text}: {e}");
    }
}

#[test]
fn m11_the_reply_and_periodic_settings_reach_the_generated_layout() {
    let d = every_type();
    let opts = gsi_codegen::Options {
        reply: 1,
        periodic: vec![(3, 32), (0, 64)],
        ..Default::default()
    };
    let src = gsi_codegen::generate(&d, &opts).expect("generates");
    for expected in [
        "pub const REPLY: DeviceProperty = DeviceProperty::Shared;",
        "pub type ReplyMessage = SharedMessage;",
        "reply: REPLY.index(),",
        "pub const PERIODIC: [Periodic; 2] = [",
        "        property: DeviceProperty::Offsets.index(),\n        period_ms: 32,",
        "        property: DeviceProperty::RsSensData.index(),\n        period_ms: 64,",
        "Some(b\"Speed\") =>",
    ] {
        assert!(src.contains(expected), "missing {expected:?}");
    }
    let bad = gsi_codegen::Options {
        reply: 4,
        ..Default::default()
    };
    assert!(
        gsi_codegen::generate(&d, &bad).is_err(),
        "index beyond the four"
    );
}

#[test]
fn m11_more_than_sixteen_properties_per_direction_is_a_build_error() {
    let mut d = every_type();
    let speed = d
        .properties
        .iter()
        .find(|p| p.name == "Speed")
        .expect("Speed")
        .clone();
    for i in 0..14 {
        let mut p = speed.clone();
        p.name = format!("Extra{i}");
        p.alias = None;
        p.pos.line = 100 + i;
        d.properties.push(p);
    }
    // 3 + 14 = 17 robot properties, 4 + 14 = 18 device properties.
    let errors = gsi_codegen::generate(&d, &Default::default()).unwrap_err();
    assert_eq!(errors.len(), 2, "{errors:?}");
    assert!(errors[0]
        .message
        .contains("more than 16 properties the controller sends"));
    assert_eq!(errors[0].pos.line, 100 + 13, "the 17th robot property");
    assert!(errors[1]
        .message
        .contains("more than 16 properties the device sends"));
}
