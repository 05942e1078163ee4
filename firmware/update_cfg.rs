// Whether the board takes updates in this build (issue 43), shared by
// the build scripts of rri-sensor and rri-diag (`include!`d), which set
// cfg `rri_update` from it: hal-board's metadata
// (`DEP_RRI_HAL_BOARD_UPDATES`) says `1` (always: the QEMU board, the
// host), `2` (only with a key of the integrator's, `RRI_UPDATE_KEY` set
// and not `off`: a product board, which takes no demonstration key) or
// `0` (never).

fn board_takes_updates() -> bool {
    println!("cargo:rerun-if-env-changed=RRI_UPDATE_KEY");
    match std::env::var("DEP_RRI_HAL_BOARD_UPDATES").as_deref() {
        Ok("1") => true,
        Ok("2") => std::env::var("RRI_UPDATE_KEY").is_ok_and(|k| !k.is_empty() && k != "off"),
        _ => false,
    }
}
