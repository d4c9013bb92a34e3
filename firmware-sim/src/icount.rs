//! Instructions executed, counted with SysTick under QEMU's deterministic `-icount shift=0`:
//! one guest instruction is 1 ns of virtual time and SysTick, clocked from the mps2-an386 core
//! clock (25 MHz), ticks every 40 ns, so one tick is 40 instructions, identical on every run.
//! (QEMU does not model the DWT cycle counter.)

use cortex_m::peripheral::SYST;
use cortex_m::peripheral::syst::SystClkSource;

/// Guest instructions per SysTick tick under `-icount shift=0` on mps2-an386.
pub const INSTRUCTIONS_PER_TICK: u32 = 40;

/// Largest SysTick reload (24-bit counter).
const RELOAD: u32 = 0x00ff_ffff;

/// A SysTick-based instruction counter. Each measurement restarts the counter, so one
/// measurement may span up to 2^24 ticks (671 M instructions).
pub struct InstructionCounter {
    syst: SYST,
}

impl InstructionCounter {
    /// Starts SysTick from the core clock, without its interrupt.
    pub fn new(mut syst: SYST) -> Self {
        syst.disable_interrupt();
        syst.set_clock_source(SystClkSource::Core);
        syst.set_reload(RELOAD);
        syst.clear_current();
        syst.enable_counter();
        InstructionCounter { syst }
    }

    /// Runs `f` and returns its value with the instructions it took (to the nearest 40), or
    /// `None` for the count when it ran past the counter's range.
    pub fn measure<T>(&mut self, f: impl FnOnce() -> T) -> (T, Option<u32>) {
        // Clearing the counter also clears COUNTFLAG; the counter stays 0 until the next tick
        // loads RELOAD, then counts down: after n >= 1 ticks it reads RELOAD + 1 - n.
        self.syst.clear_current();
        let value = f();
        let current = SYST::get_current();
        let wrapped = self.syst.has_wrapped();
        let ticks = if current == 0 {
            0
        } else {
            RELOAD + 1 - current
        };
        let count = (!wrapped).then(|| ticks.saturating_mul(INSTRUCTIONS_PER_TICK));
        (value, count)
    }
}
