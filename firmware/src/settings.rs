//! The board's saved settings (issue 36): the store (`flexarm_machine::store`) over this board's
//! non-volatile memory, loaded at boot and written by the link's `ConfigSave` / `ConfigErase`.
//!
//! - Hardware: the STM32F405's flash sectors 10 and 11 (128 KiB each, 0x080C_0000 to
//!   0x0810_0000), outside the image (`memory.x` gives the image the first 768 KiB), through the
//!   flash interface's registers (RM0090 §3.6: unlock, sector erase, 32-bit programming at
//!   VDD 2.7–3.6 V). An erase or a program stalls every fetch from the flash, so every loop,
//!   while it runs: a sector erase takes 1 s typical, 2 s at most (datasheet, t_ERASE128KB at
//!   x32), a save's 33 words about 0.5 ms. The link refuses a save while armed; during an erase
//!   the independent watchdog is slowed to its longest timeout (32 s) and set back after.
//! - QEMU: its STM32F405 models the flash as ROM and not the flash interface (writes are
//!   ignored), so the store is 512 B of RAM that the start-up does not zero (`.uninit`, beside
//!   the fault recorder): the settings survive a reset (`SCB::sys_reset`, QEMU's
//!   `system_reset`) but not a power cycle (a new QEMU process), which finds the RAM without
//!   its mark and starts with an erased store.

use embedded_storage_async::nor_flash::{ErrorType, NorFlash, ReadNorFlash};
use flexarm_core::drive::Drive;
use flexarm_link::msg::{Refusal, Reply, Settings, SettingsRefusal};
use flexarm_machine::store::{FlashError, Loaded, Store};
use flexarm_machine::{Control, Session};

/// The board's store.
pub type BoardStore = Store<BoardFlash>;

/// The store over this board's memory (`init`'s: no flash is read yet).
pub fn take() -> Option<BoardStore> {
    let store = BoardFlash::take().and_then(|f| Store::new(f, RANGE));
    if store.is_none() {
        defmt::error!("settings: the store's pages are not on the flash's page boundaries");
    }
    store
}

/// What the store holds, applied to the controller and the drive through a `Set`'s checks,
/// one value under one short lock at a time (`Session::apply`): the idle task's first act,
/// while the loops run disarmed and before any request is served. The handshake and the log
/// say what happened.
#[inline(never)]
pub fn boot(
    store: &mut Option<BoardStore>,
    session: &mut Session,
    control: &mut impl rtic::Mutex<T = Control>,
    drive: &mut impl rtic::Mutex<T = Drive<f32>>,
) {
    let loaded = match store {
        Some(s) => s.load(crate::config::CONFIG_HASH),
        None => Loaded::Refused(SettingsRefusal::Unreadable),
    };
    let settings = match loaded {
        Loaded::Nothing | Loaded::Erased => Settings::Defaults,
        Loaded::Refused(r) => Settings::Refused(r),
        Loaded::Values(v) => match session.apply(&v, control, drive) {
            Ok(()) => Settings::Loaded,
            Err(p) => Settings::Refused(SettingsRefusal::Value(p)),
        },
    };
    match settings {
        Settings::Loaded => defmt::info!("settings: the saved settings run"),
        Settings::Refused(_) => {
            defmt::warn!("settings: the saved settings were refused; the build's defaults run")
        }
        _ => defmt::info!("settings: nothing saved; the build's defaults run"),
    }
    session.set_settings(settings);
}

/// `ConfigSave` (`save`) or `ConfigErase`: disarmed only (the drive disarmed or faulted, the
/// amplifiers off), the values read under a short lock, the store written outside every lock.
/// No other request is served meanwhile (the idle task serves them in turn), so none arms the
/// drive between the check and the write.
#[inline(never)]
pub fn serve(
    save: bool,
    session: &mut Session,
    control: &mut impl rtic::Mutex<T = Control>,
    drive: &mut impl rtic::Mutex<T = Drive<f32>>,
    store: &mut Option<BoardStore>,
) -> Reply {
    let values = control.lock(|c| {
        drive.lock(|d| {
            d.heard(d.next_tick());
            matches!(
                d.mode(&c.ctrl),
                flexarm_core::drive::Mode::Disarmed | flexarm_core::drive::Mode::Fault
            )
            .then(|| session.values(c, d))
        })
    });
    let Some(values) = values else {
        return Reply::Refused(Refusal::Armed);
    };
    let Some(store) = store else {
        return Reply::Refused(Refusal::Storage);
    };
    let written = if save {
        store.save(&values, crate::config::CONFIG_HASH)
    } else {
        store.erase()
    };
    match written {
        Ok(()) => {
            session.set_settings(if save {
                Settings::Saved
            } else {
                Settings::Erased
            });
            defmt::info!("settings: {=str}", if save { "saved" } else { "erased" });
            Reply::Done
        }
        Err(_) => {
            defmt::warn!("settings: the store failed");
            Reply::Refused(Refusal::Storage)
        }
    }
}

#[cfg(feature = "qemu")]
pub use ram::{BoardFlash, RANGE};

#[cfg(feature = "qemu")]
#[allow(unsafe_code)]
mod ram {
    use super::*;
    use core::mem::MaybeUninit;

    /// The RAM store's size: two pages of 256 B (one record each: the static RAM budget).
    const SIZE: usize = 512;
    /// Its pages.
    const PAGE: usize = 256;
    /// The mark of a RAM store that a previous boot formatted (absent after a power-on).
    const MAGIC: u32 = 0x5e77_1265;

    /// The store's range in [`BoardFlash`]'s addresses.
    pub const RANGE: core::ops::Range<u32> = 0..SIZE as u32;

    #[repr(C, align(4))]
    pub struct Region {
        magic: u32,
        mem: [u8; SIZE],
    }

    #[unsafe(link_section = ".uninit.flexarm.settings")]
    static mut REGION: MaybeUninit<Region> = MaybeUninit::uninit();

    /// The QEMU board's store: RAM that survives a reset, programmed and erased as a NOR flash
    /// (erase to 0xFF, program 1 → 0).
    pub struct BoardFlash(&'static mut Region);

    impl BoardFlash {
        /// The region, formatted (erased) after a power-on. Called once, by `init`.
        pub fn take() -> Option<Self> {
            // SAFETY: called once, before any task runs, and nothing else names the static;
            // every bit pattern is a value of `Region` (integers only). Through an opaque
            // pointer, as the retained stores (`retained::opaque`): the compiler may not fold
            // the magic's check.
            let r = unsafe { (*core::hint::black_box(&raw mut REGION)).assume_init_mut() };
            if core::hint::black_box(r.magic) != MAGIC {
                r.mem.fill(0xFF);
                r.magic = MAGIC;
            }
            Some(Self(r))
        }
    }

    impl ErrorType for BoardFlash {
        type Error = FlashError;
    }

    impl ReadNorFlash for BoardFlash {
        const READ_SIZE: usize = 1;
        async fn read(&mut self, offset: u32, bytes: &mut [u8]) -> Result<(), FlashError> {
            let o = offset as usize;
            let src = self.0.mem.get(o..o + bytes.len()).ok_or(FlashError)?;
            bytes.copy_from_slice(src);
            Ok(())
        }
        fn capacity(&self) -> usize {
            SIZE
        }
    }

    impl NorFlash for BoardFlash {
        const WRITE_SIZE: usize = 4;
        const ERASE_SIZE: usize = PAGE;
        async fn erase(&mut self, from: u32, to: u32) -> Result<(), FlashError> {
            self.0
                .mem
                .get_mut(from as usize..to as usize)
                .ok_or(FlashError)?
                .fill(0xFF);
            Ok(())
        }
        async fn write(&mut self, offset: u32, bytes: &[u8]) -> Result<(), FlashError> {
            let o = offset as usize;
            let dst = self.0.mem.get_mut(o..o + bytes.len()).ok_or(FlashError)?;
            for (d, b) in dst.iter_mut().zip(bytes) {
                *d &= *b;
            }
            Ok(())
        }
    }
}

#[cfg(not(feature = "qemu"))]
pub use flash::{BoardFlash, RANGE};

#[cfg(not(feature = "qemu"))]
#[allow(unsafe_code)]
mod flash {
    use super::*;
    use stm32f4::stm32f405::{FLASH, IWDG};

    /// The flash's base address.
    const BASE: u32 = 0x0800_0000;
    /// The store's first sector (10) and its size: sectors 10 and 11, 128 KiB each.
    const FIRST_SECTOR: u8 = 10;
    const SECTOR: u32 = 128 * 1024;
    /// The store's range in [`BoardFlash`]'s addresses (offsets from the flash's base):
    /// 0x080C_0000 to 0x0810_0000.
    pub const RANGE: core::ops::Range<u32> = 0xC_0000..0x10_0000;

    /// The hardware board's store: flash sectors 10 and 11 through the flash interface.
    pub struct BoardFlash;

    impl BoardFlash {
        /// The driver. Called once, by `init`.
        pub fn take() -> Option<Self> {
            Some(Self)
        }

        fn regs() -> &'static stm32f4::stm32f405::flash::RegisterBlock {
            // SAFETY: only the idle task uses the flash interface after `init` set the wait
            // states (ACR, which this code does not touch).
            unsafe { &*FLASH::ptr() }
        }

        /// Runs `f` with the flash unlocked, waits for it, checks the errors, locks it.
        fn with_unlocked(
            f: impl FnOnce(&stm32f4::stm32f405::flash::RegisterBlock),
        ) -> Result<(), FlashError> {
            let r = Self::regs();
            while r.sr().read().bsy().bit_is_set() {}
            // Clear the previous errors (write 1 to clear).
            r.sr().write(|w| unsafe { w.bits(0xF3) });
            if r.cr().read().lock().bit_is_set() {
                r.keyr().write(|w| unsafe { w.key().bits(0x4567_0123) });
                r.keyr().write(|w| unsafe { w.key().bits(0xCDEF_89AB) });
            }
            f(r);
            while r.sr().read().bsy().bit_is_set() {}
            let errors = r.sr().read().bits() & 0xF2;
            r.cr().write(|w| w.lock().set_bit());
            // The ART accelerator's data cache may hold the words before the operation: reset
            // it (RM0090 §3.5.2: only while disabled).
            if r.acr().read().dcen().bit_is_set() {
                r.acr().modify(|_, w| w.dcen().clear_bit());
                r.acr().modify(|_, w| w.dcrst().set_bit());
                r.acr().modify(|_, w| w.dcrst().clear_bit());
                r.acr().modify(|_, w| w.dcen().set_bit());
            }
            if errors == 0 { Ok(()) } else { Err(FlashError) }
        }
    }

    /// The watchdog at its longest timeout (prescaler 256: 32.8 s at 32 kHz) while `f` runs,
    /// then at the prescaler it had (a sector erase stalls the supervisor that feeds it).
    fn watchdog_slowed<T>(f: impl FnOnce() -> T) -> T {
        // SAFETY: the supervisor only writes KR (the feed), which is atomic; PR is written
        // here and at start-up only.
        let iwdg = unsafe { &*IWDG::ptr() };
        let set = |pr: u8| {
            iwdg.kr().write(|w| w.key().feed());
            iwdg.kr().write(|w| w.key().unlock());
            iwdg.pr().write(|w| w.pr().set(pr));
            for _ in 0..100_000 {
                if iwdg.sr().read().pvu().bit_is_clear() {
                    break;
                }
            }
            iwdg.kr().write(|w| w.key().feed());
        };
        let was = iwdg.pr().read().pr().bits();
        set(6);
        let r = f();
        set(was);
        r
    }

    impl ErrorType for BoardFlash {
        type Error = FlashError;
    }

    impl ReadNorFlash for BoardFlash {
        const READ_SIZE: usize = 1;
        async fn read(&mut self, offset: u32, bytes: &mut [u8]) -> Result<(), FlashError> {
            if !(RANGE.start..=RANGE.end).contains(&(offset + bytes.len() as u32))
                || offset < RANGE.start
            {
                return Err(FlashError);
            }
            for (i, b) in bytes.iter_mut().enumerate() {
                // SAFETY: within the store's sectors, memory-mapped flash.
                *b = unsafe { core::ptr::read_volatile((BASE + offset + i as u32) as *const u8) };
            }
            Ok(())
        }
        fn capacity(&self) -> usize {
            RANGE.end as usize
        }
    }

    impl NorFlash for BoardFlash {
        const WRITE_SIZE: usize = 4;
        const ERASE_SIZE: usize = SECTOR as usize;
        async fn erase(&mut self, from: u32, to: u32) -> Result<(), FlashError> {
            if from < RANGE.start || to > RANGE.end {
                return Err(FlashError);
            }
            for at in (from..to).step_by(SECTOR as usize) {
                let sector = FIRST_SECTOR + ((at - RANGE.start) / SECTOR) as u8;
                watchdog_slowed(|| {
                    Self::with_unlocked(|r| {
                        // PSIZE x32, sector erase of `sector`, start.
                        r.cr().write(|w| unsafe {
                            w.psize().bits(0b10).ser().set_bit().snb().bits(sector)
                        });
                        r.cr().modify(|_, w| w.strt().set_bit());
                    })
                })?;
            }
            Ok(())
        }
        async fn write(&mut self, offset: u32, bytes: &[u8]) -> Result<(), FlashError> {
            if offset < RANGE.start
                || offset + bytes.len() as u32 > RANGE.end
                || !offset.is_multiple_of(4)
            {
                return Err(FlashError);
            }
            for (i, w) in bytes.chunks_exact(4).enumerate() {
                let word = u32::from_le_bytes([w[0], w[1], w[2], w[3]]);
                let at = BASE + offset + 4 * i as u32;
                Self::with_unlocked(|r| {
                    r.cr()
                        .write(|w| unsafe { w.psize().bits(0b10).pg().set_bit() });
                    // SAFETY: a word of the store's sectors, with PG set (RM0090 §3.6.4).
                    unsafe { core::ptr::write_volatile(at as *mut u32, word) };
                })?;
            }
            Ok(())
        }
    }
}
