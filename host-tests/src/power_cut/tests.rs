//! `power_cut`'s verdicts on what a cut run logged and answered.

use super::*;

#[test]
fn an_image_left_on_trial_after_the_cut_is_seen() {
    let cut = "rehost: power cut at flash operation 9 (cycle 1)\n";
    let trial = "device: update: version 0.1.1 was just swapped in, replacing version 0.1.0, and is on trial: it confirms itself\n";
    let confirmed = "device: update: version 0.1.1 confirmed: OPERATING\n";
    assert!(ends_confirmed(&format!("{cut}{trial}{confirmed}")));
    assert!(!ends_confirmed(&format!("{cut}{trial}")));
    // A trial before the cut is not the one that counts.
    assert!(!ends_confirmed(&format!("{trial}{confirmed}{cut}{trial}")));
    assert!(ends_confirmed(&format!("{trial}{cut}")));
    assert!(!ends_confirmed("no cut at all"));
}

#[test]
fn b_is_taken_once_whichever_attempt_carried_it() {
    let marked = Ok((200, "version 0.1.1 checked and marked: ...".to_string()));
    let already = Ok((
        409,
        "refused: an update is marked already, or ...".to_string(),
    ));
    let died = Err("no answer".to_string());
    assert!(b_taken(&died, &marked));
    assert!(b_taken(&marked, &already));
    // Marked by neither, or refused though nothing was marked.
    assert!(!b_taken(&died, &already));
    assert!(!b_taken(&died, &died));
    assert!(!b_taken(
        &marked,
        &Ok((403, "refused: signature".to_string()))
    ));
    // B running: the cut fell after the mark; A: it must have taken B.
    let v = ("0.1.0", "0.1.1");
    assert!(upload_cut_ended_well("0.1.1", v, &died, &marked));
    assert!(upload_cut_ended_well("0.1.0", v, &died, &marked));
    assert!(!upload_cut_ended_well("0.1.0", v, &died, &already));
    assert!(!upload_cut_ended_well("", v, &died, &marked));
}

#[test]
fn the_version_is_the_last_start_after_the_cut() {
    let log = "device: rri-sensor 0.1.0 on NUCLEO\nrehost: power cut at flash operation 4 (cycle 1)\ndevice: rri-sensor 0.1.1 on NUCLEO-H743ZI2: AnyDevice\n";
    assert_eq!(version_after_cut(log).as_deref(), Some("0.1.1"));
    assert_eq!(version_after_cut("device: rri-sensor 0.1.0 on X\n"), None);
}
