//! The host sensor's diagnostics against the robot simulator's own
//! counts: a run with every kind of injected loss (`cargo robot`'s
//! faults), and each of them found on the right side of the wire in
//! `/status.json`; `/metrics` read by a strict exposition-format parser
//! and agreeing with the JSON.

use host_tests::robot::{self, RobotOptions};
use host_tests::sensor::Background;
use rri_firmware::layout;

#[test]
fn every_injected_loss_shows_on_the_right_side_of_the_wire() {
    let sensor = Background::start_diagnosed(false, layout::ENGINE_CONFIG).expect("starts");
    let http = sensor.http.expect("diagnostics");
    let gsi = host_tests::workspace().join("firmware/gsi/GSI");
    let device = gsi_config::load(&gsi, None).unwrap().device;
    let mut opts = RobotOptions::new(gsi, sensor.addr);
    opts.cycles = 600;
    opts.pacing = false;
    opts.seed = 7;
    opts.faults = ["drop:3", "duplicate:3", "garbage:3", "oversize:1"]
        .iter()
        .map(|f| robot::fault::Fault::parse(f).unwrap())
        .collect();
    opts.device_status = Some(format!("http://{http}/"));
    let (s, _) = robot::run(&opts, &device, &mut std::io::sink()).expect("runs");
    let c = s.device_status.clone().expect("the device's side");
    let row = |what: &str| {
        c.rows
            .iter()
            .find(|r| r.what.starts_with(what))
            .unwrap()
            .clone()
    };
    let i = &s.injected;
    assert!(
        i.dropped > 0 && i.duplicated > 0 && i.garbage > 0 && i.oversize > 0,
        "{i:?}"
    );
    // Every message sent reached the engine (loopback loses nothing), and
    // every answer arrived.
    let taken = row("robot messages");
    assert_eq!(
        (taken.simulator, taken.device),
        (s.sent + i.duplicated, s.sent + i.duplicated)
    );
    let replies = row("replies");
    assert_eq!(replies.simulator, replies.device);
    // The garbage and the oversize datagrams are the decoder's rejections,
    // the duplicates its duplicates; the skipped Ids its lost ones.
    assert_eq!(row("malformed").simulator, row("malformed").device);
    assert_eq!(row("messages duplicated").device, i.duplicated);
    assert_eq!(row("Ids skipped").device, i.dropped);
    assert!(!c.in_firmware, "{:?}", c.disagreements);
    assert!(c.disagreements.is_empty(), "{:?}", c.disagreements);

    // /metrics agrees with the JSON.
    let metrics = robot::device_status::get(
        &format!("http://{http}/metrics"),
        std::time::Duration::from_secs(5),
    )
    .unwrap();
    assert_eq!(metrics.status, 200);
    let text = String::from_utf8(metrics.body).unwrap();
    let m =
        openmetrics_parser::prometheus::parse_prometheus(&text).unwrap_or_else(|e| panic!("{e:?}"));
    let answered = m.families["rri_messages_total"]
        .iter_samples()
        .find(|x| x.get_labelset().unwrap().get_label_value("outcome") == Some("answered"))
        .map(|x| match &x.value {
            openmetrics_parser::PrometheusValue::Counter(c) => c.value.as_f64() as u64,
            v => panic!("{v:?}"),
        })
        .unwrap();
    let json = robot::device_status::DeviceCounts::read(&format!("http://{http}/")).unwrap();
    assert_eq!(answered, json.answered);
    let decode: f64 = m.families["rri_decode_errors_total"]
        .iter_samples()
        .map(|x| match &x.value {
            openmetrics_parser::PrometheusValue::Counter(c) => c.value.as_f64(),
            v => panic!("{v:?}"),
        })
        .sum();
    assert_eq!(decode as u64, json.dropped_decode);
    sensor.stop().expect("stops");
}

#[test]
fn the_host_sensor_serves_the_boards_page_and_refuses_what_a_board_refuses() {
    let sensor = Background::start_diagnosed(false, layout::ENGINE_CONFIG).expect("starts");
    let http = sensor.http.expect("diagnostics");
    let get = |path: &str| {
        robot::device_status::get(
            &format!("http://{http}{path}"),
            std::time::Duration::from_secs(5),
        )
        .unwrap()
    };
    let page = get("/");
    assert_eq!(page.status, 200);
    // No gzip asked for: the note that points at the JSON.
    assert!(String::from_utf8_lossy(&page.body).contains("/status.json"));
    assert_eq!(get("/nope").status, 404);
    let json = get("/status.json");
    let v: serde_json::Value = serde_json::from_slice(&json.body).unwrap();
    assert_eq!(v["device"]["board"], "host (cargo sensor-host)");
    assert_eq!(v["latency"]["source"], "socket");
    sensor.stop().expect("stops");
}
