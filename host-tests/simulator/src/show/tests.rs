//! Field lookup against real GSI layouts and value extraction from reply
//! datagrams written as a sensor writes them (M1–M4).

use super::*;
use std::path::PathBuf;

fn device(dir: &str) -> Device {
    let gsi = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join(dir);
    gsi_config::load(&gsi, None).expect("GSI loads").device
}

/// The manual's AnyDevice: `SensData` = `EStr` (string), `AppData` (num[18]).
fn any() -> Device {
    device("../../firmware/gsi/GSI")
}

/// Every simple type, an enum, a frame, joints and an array in a reply.
fn every() -> Device {
    device("../gsi/every-type/GSI")
}

fn reply<'d>(d: &'d Device, name: &str) -> &'d Property {
    d.sent().find(|p| p.is_named(name)).expect("property")
}

fn names(s: &[&str]) -> Vec<String> {
    s.iter().map(|n| n.to_string()).collect()
}

fn labels(show: &Show) -> Vec<&str> {
    show.labels()
}

#[test]
fn fields_by_name_alias_any_case_and_component() {
    let d = any();
    let p = reply(&d, "SensData");
    let s = Show::resolve(
        &d,
        p,
        &names(&["appdata.x3", "ErrorString", "SensData.AppData.X18"]),
    )
    .expect("resolves");
    assert_eq!(labels(&s), ["AppData.X3", "EStr", "AppData.X18"]);
    assert_eq!(
        s.columns.iter().map(|c| c.numeric).collect::<Vec<_>>(),
        [true, false, true]
    );
    // A multi-value field alone: every component.
    let all = Show::resolve(&d, p, &names(&["ApplicationData"])).expect("resolves");
    assert_eq!(all.columns.len(), 18);
    assert_eq!(all.columns[17].label, "AppData.X18");
}

#[test]
fn an_unknown_field_or_component_lists_the_available_ones() {
    let d = any();
    let p = reply(&d, "SensData");
    for bad in [
        "Distance",
        "AppData.X19",
        "AppData.X",
        "EStr.X1",
        "AppData.X1.Y",
    ] {
        let e = Show::resolve(&d, p, &names(&[bad])).expect_err(bad);
        assert!(e.contains(&format!("--show {bad}: no such field")), "{e}");
        assert!(e.contains("available: EStr, AppData.X1, AppData.X2"), "{e}");
    }
    let e = Show::resolve(&d, p, &names(&[" "])).expect_err("nothing named");
    assert!(e.contains("at least one field"), "{e}");
}

#[test]
fn frames_joints_and_simple_properties() {
    let d = every();
    let p = reply(&d, "SensData");
    let s = Show::resolve(&d, p, &names(&["Corr.Rz", "axes.j6", "Correction"])).expect("ok");
    assert_eq!(
        labels(&s),
        ["Corr.Rz", "Axes.J6", "Corr.X", "Corr.Y", "Corr.Z", "Corr.Rx", "Corr.Ry", "Corr.Rz"]
    );
    // A simple-typed array property: its components, with or without
    // the property's name in front.
    let o = reply(&d, "Offsets");
    let s = Show::resolve(&d, o, &names(&["Offsets.X2", "X3"]));
    assert_eq!(
        s.map(|s| labels(&s).iter().map(|l| l.to_string()).collect::<Vec<_>>()),
        Err(format!(
            "--show X3: no such field in the reply <Offsets> of device {}; available: Offsets.X1, Offsets.X2, Offsets.X3",
            d.name
        ))
    );
    let s = Show::resolve(&d, o, &names(&["offsets.x2", "Offsets"])).expect("ok");
    assert_eq!(
        labels(&s),
        ["Offsets.X2", "Offsets.X1", "Offsets.X2", "Offsets.X3"]
    );
}

#[test]
fn values_from_a_reply_datagram() {
    let d = every();
    let p = reply(&d, "SensData");
    let s = Show::resolve(
        &d,
        p,
        &names(&[
            "EStr",
            "Valid",
            "Distance",
            "Measured",
            "Corr.Y",
            "Axes.J2",
            "Phase",
            "AppData.X20",
        ]),
    )
    .expect("ok");
    let appdata: String = (1..=20).map(|i| format!(" X{i}=\"{}\"", i * 10)).collect();
    let text = format!(
        "<SensData Id=\"77\" Ts=\"12.5\"><EStr>a &amp; b, &quot;c&quot;</EStr><Valid>TRUE</Valid>\
         <Distance>-1.25e-03</Distance><Measured>3.000250</Measured>\
         <Corr X=\"1\" Y=\"2.5\" Z=\"3\" Rx=\"0\" Ry=\"0\" Rz=\"0\"/>\
         <Axes J1=\"1\" J2=\"-90\" J3=\"0\" J4=\"0\" J5=\"0\" J6=\"0\"/>\
         <Phase>Idle</Phase><AppData{appdata}/></SensData>"
    );
    let (ts, v) = s.extract(text.as_bytes()).expect("xml");
    assert_eq!(ts, Some(12.5));
    assert_eq!(
        v,
        [
            Cell::Text("a & b, \"c\"".into()),
            Cell::Bool(true),
            Cell::Num(-0.00125),
            Cell::Num(3.00025),
            Cell::Num(2.5),
            Cell::Num(-90.0),
            Cell::Text("Idle".into()),
            Cell::Num(200.0),
        ]
    );
    assert_eq!(
        line(&s, 77, &v[..3]),
        "reply to Id 77:  EStr=a & b, \"c\"  Valid=TRUE  Distance=-0.00125"
    );
    // A slot the reply lacks is missing, not another slot's value.
    let (_, v) = s
        .extract(b"<SensData Id=\"1\" Ts=\"0\"><Valid>FALSE</Valid></SensData>")
        .expect("xml");
    assert_eq!(v[0], Cell::Missing);
    assert_eq!(v[1], Cell::Bool(false));
    assert_eq!(v[7], Cell::Missing);
    assert!(s.extract(b"\xff\xfe").is_none());
}

#[test]
fn values_of_a_simple_typed_array_reply() {
    let d = every();
    let s = Show::resolve(&d, reply(&d, "Offsets"), &names(&["X3", "Offsets.X1"]));
    assert!(s.is_err(), "a bare component is no field");
    let s = Show::resolve(
        &d,
        reply(&d, "Offsets"),
        &names(&["Offsets.X3", "Offsets.X1"]),
    )
    .expect("ok");
    let (ts, v) = s
        .extract(b"<Offsets Id=\"5\" Ts=\"1\" X1=\"0.5\" X2=\"7\" X3=\"-3\"/>")
        .expect("xml");
    assert_eq!((ts, v), (Some(1.0), vec![Cell::Num(-3.0), Cell::Num(0.5)]));
}

#[test]
fn csv_rows_per_answered_reply_with_quoted_text() {
    let d = any();
    let s = Show::resolve(&d, reply(&d, "SensData"), &names(&["AppData.X1", "EStr"])).expect("ok");
    let cycles = vec![
        Cycle {
            id: 9,
            reply_us: Some(1_500_000),
            shown: Some(Shown {
                ts: Some(2.25),
                values: vec![Cell::Num(0.5), Cell::Text("OK, \"fine\"".into())],
            }),
            ..Cycle::default()
        },
        // Lost: no row.
        Cycle {
            id: 10,
            ..Cycle::default()
        },
    ];
    let path = std::env::temp_dir().join(format!("rri-show-{}.csv", std::process::id()));
    write_csv(&path, &s, &cycles).expect("written");
    let text = std::fs::read_to_string(&path).expect("read");
    let _ = std::fs::remove_file(&path);
    assert_eq!(
        text,
        "id,reply_s,reply_ts,AppData.X1,EStr\n9,1.500000,2.25,0.5,\"OK, \"\"fine\"\"\"\n"
    );
}
