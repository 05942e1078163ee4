//! unicorn's Cortex-M7 as the machine sets it up executes what the
//! images contain: the double-precision FPU (FPv5-D16, both chips).

use unicorn_engine::{Arch, ArmCpuModel, Mode, Prot, RegisterARM, Unicorn};

#[test]
fn the_cortex_m7_model_divides_in_double_precision() {
    // Not Mode::MCLASS: with it unicorn builds a Cortex-M33 whatever model
    // is asked for (qemu/target/arm/cpu.c, arm_cpu_init); the M7 model is
    // an M-profile core by itself.
    let mut uc = Unicorn::new(Arch::ARM, Mode::THUMB).unwrap();
    uc.ctl_set_cpu_model(ArmCpuModel::CORTEX_M7 as i32).unwrap();
    assert_eq!(
        uc.ctl_get_cpu_model().unwrap(),
        ArmCpuModel::CORTEX_M7 as i32
    );
    uc.mem_map(0x1000, 0x1000, Prot::ALL).unwrap();
    // vdiv.f64 d1, d0, d8
    let code = [0x80, 0xee, 0x08, 0x1b];
    uc.mem_write(0x1000, &code).unwrap();
    uc.reg_write(RegisterARM::D0, 6.0f64.to_bits()).unwrap();
    uc.reg_write(RegisterARM::D8, 4.0f64.to_bits()).unwrap();
    uc.emu_start(0x1001, 0x1004, 0, 1).unwrap();
    assert_eq!(f64::from_bits(uc.reg_read(RegisterARM::D1).unwrap()), 1.5);
}
