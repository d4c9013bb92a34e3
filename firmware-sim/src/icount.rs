//! Instructions executed, counted with SysTick under QEMU's deterministic `-icount shift=0`:
//! one guest instruction is 1 ns of virtual time and SysTick, clocked from the mps2-an386 core
//! clock (25 MHz), ticks every 40 ns, so one tick is 40 instructions, identical on every run.
//! (QEMU does not model the DWT cycle counter.) The 24-bit counter wraps every 671 M
//! instructions; its exception counts the wraps, so a measurement has no practical limit (the
//! grey-level fit takes more than one wrap a frame).

use core::sync::atomic::{AtomicU32, Ordering};
use cortex_m::peripheral::SYST;
use cortex_m::peripheral::syst::SystClkSource;

/// Guest instructions per SysTick tick under `-icount shift=0` on mps2-an386.
pub const INSTRUCTIONS_PER_TICK: u64 = 40;

/// Largest SysTick reload (24-bit counter).
const RELOAD: u32 = 0x00ff_ffff;

/// The counter's wraps (its count reaching 0) since the measurement began.
static WRAPS: AtomicU32 = AtomicU32::new(0);

#[cortex_m_rt::exception]
fn SysTick() {
    WRAPS.fetch_add(1, Ordering::Relaxed);
}

/// A SysTick-based instruction counter; each measurement restarts it.
pub struct InstructionCounter {
    syst: SYST,
}

impl InstructionCounter {
    /// Starts SysTick from the core clock, its exception counting the wraps.
    pub fn new(mut syst: SYST) -> Self {
        syst.set_clock_source(SystClkSource::Core);
        syst.set_reload(RELOAD);
        syst.clear_current();
        syst.enable_interrupt();
        syst.enable_counter();
        InstructionCounter { syst }
    }

    /// Runs `f` and returns its value with the instructions it took, to the nearest 40 (the
    /// exceptions at the wraps, a few instructions each, included).
    pub fn measure<T>(&mut self, f: impl FnOnce() -> T) -> (T, u64) {
        // Clearing the counter leaves it at 0 until the next tick loads RELOAD, then it counts
        // down: after n ticks, 1 <= n <= RELOAD + 1, it reads RELOAD + 1 - n, and reaching 0
        // (a wrap) raises the exception.
        self.syst.clear_current();
        WRAPS.store(0, Ordering::Relaxed);
        let value = f();
        // The wraps read on both sides of the count, so that a wrap between the two reads is
        // not taken with the count from before it.
        let (wraps, current) = loop {
            let before = WRAPS.load(Ordering::Relaxed);
            let current = SYST::get_current();
            if WRAPS.load(Ordering::Relaxed) == before {
                break (before, current);
            }
        };
        let ticks = u64::from(wraps) * (u64::from(RELOAD) + 1)
            + if current == 0 {
                0
            } else {
                u64::from(RELOAD + 1 - current)
            };
        (value, ticks * INSTRUCTIONS_PER_TICK)
    }
}
