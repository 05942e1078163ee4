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

/// What the MPU model (src/mpu.rs) relies on: a page protected from
/// writes sends every store into it to the WRITE_PROT hook; a store the
/// hook performs itself (returning true) goes on, and one it refuses
/// (false) stops the core precisely on that instruction, nothing after it
/// executed and the store not done.
#[test]
fn a_refused_write_to_a_protected_page_stops_on_its_instruction() {
    use unicorn_engine::{HookType, MemType};
    let mut uc = Unicorn::new_with_data(Arch::ARM, Mode::THUMB, None::<u64>).unwrap();
    uc.ctl_set_cpu_model(ArmCpuModel::CORTEX_M7 as i32).unwrap();
    uc.mem_map(0x1000, 0x1000, Prot::ALL).unwrap();
    uc.mem_map(0x2000_0000, 0x4000, Prot::ALL).unwrap();
    let page = uc.ctl_get_page_size().unwrap();
    assert_eq!(page, 1024, "M-profile cores get 1 KiB pages");
    uc.mem_protect(0x2000_0400, u64::from(page), Prot::READ | Prot::EXEC)
        .unwrap();
    // str r0,[r1]; str r0,[r2]; str r0,[r3]; adds r4,#1; str r0,[r5]; b .
    let code: [u16; 6] = [0x6008, 0x6010, 0x6018, 0x3401, 0x6028, 0xe7fe];
    let bytes: Vec<u8> = code.iter().flat_map(|c| c.to_le_bytes()).collect();
    uc.mem_write(0x1000, &bytes).unwrap();
    let set = |uc: &mut Unicorn<_>, r3: u64| {
        for (r, v) in [
            (RegisterARM::R0, 0xAABB_CCDD),
            (RegisterARM::R1, 0x2000_0500),
            (RegisterARM::R2, 0x2000_0100),
            (RegisterARM::R3, r3),
            (RegisterARM::R4, 0),
            (RegisterARM::R5, 0x2000_0200),
        ] {
            uc.reg_write(r, v).unwrap();
        }
    };
    uc.add_mem_hook(HookType::MEM_WRITE_PROT, 1, 0, |uc, kind, addr, size, v| {
        assert_eq!(kind, MemType::WRITE_PROT);
        if (0x2000_0400..0x2000_0480).contains(&addr) {
            *uc.get_data_mut() = uc.reg_read(RegisterARM::PC).ok();
            let _ = uc.emu_stop();
            return false;
        }
        uc.mem_write(addr, &(v as u32).to_le_bytes()[..size])
            .unwrap();
        true
    })
    .unwrap();
    let word = |uc: &Unicorn<_>, a: u64| {
        let mut b = [0u8; 4];
        uc.mem_read(a, &mut b).unwrap();
        u32::from_le_bytes(b)
    };
    // Every write allowed: the protected page's taken by the hook.
    set(&mut uc, 0x2000_0504);
    uc.emu_start(0x1001, 0x100a, 0, 0).unwrap();
    assert_eq!(uc.reg_read(RegisterARM::R4).unwrap(), 1);
    assert_eq!(word(&uc, 0x2000_0504), 0xAABB_CCDD);
    // The third store refused: stopped on it.
    set(&mut uc, 0x2000_0404);
    uc.mem_write(0x2000_0200, &[0; 4]).unwrap();
    assert!(uc.emu_start(0x1001, 0x100a, 0, 0).is_err());
    assert_eq!(*uc.get_data(), Some(0x1004), "the hook saw the store's PC");
    assert_eq!(uc.reg_read(RegisterARM::PC).unwrap(), 0x1004);
    assert_eq!(
        uc.reg_read(RegisterARM::R4).unwrap(),
        0,
        "nothing after it ran"
    );
    assert_eq!(word(&uc, 0x2000_0404), 0, "the refused store not done");
    assert_eq!(word(&uc, 0x2000_0200), 0);
}
