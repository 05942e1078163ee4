//! `--until`: a run that ends when the core reaches a function's entry.

use super::Machine;
use unicorn_engine::RegisterARM;

impl Machine {
    /// Ends the run when the core reaches `addr` (a function's entry).
    pub fn stop_at(&mut self, addr: u64) -> Result<(), String> {
        let addr = addr & !1;
        self.uc
            .add_code_hook(addr, addr, |uc, _, _| {
                let pc = uc.reg_read(RegisterARM::PC).unwrap_or(0);
                let s = uc.get_data_mut();
                s.reached = true;
                s.refuse("reached".into(), None, pc);
                let _ = uc.emu_stop();
            })
            .map(|_| ())
            .map_err(|e| format!("unicorn: code hook: {e:?}"))
    }

    /// Whether the run ended at the address given to [`Machine::stop_at`].
    pub fn reached(&self) -> bool {
        self.uc.get_data().reached
    }
}
