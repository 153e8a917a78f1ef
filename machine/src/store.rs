//! The board's saved settings (issue 36): the values of the tunable parameters a board's
//! configuration holds (every one but `va_bias`), kept in non-volatile memory and loaded at
//! boot.
//!
//! The store is `sequential-storage`'s key-value map over the `embedded-storage-async` NOR-flash
//! traits, in (at least) two erase pages: a save appends a new item after the old one, and an
//! item counts only once it is complete and its CRC checks, so a power cut at any point of a
//! write or an erase leaves the previous save readable (the crate's page states and its repair
//! at the next access; `machine/tests/store.rs` cuts the power at every word written and every
//! page erased and checks it). Its futures complete without waiting (the boards' flash drivers
//! never return `Pending`): [`block_on`] polls them once each.
//!
//! The record ([`encode`]) carries its own version and CRC besides the item's:
//! `schema u16 ‖ link::VERSION u16 ‖ params_hash u32 ‖ n u8 ‖ n × (param u8 ‖ value f32) ‖
//! CRC-32 u32`, little-endian; an empty record marks the settings erased (`config erase`). A
//! record saved by a build of another schema, protocol version or configuration hash is
//! refused at boot ([`SettingsRefusal`]), and the build's defaults run.

use core::future::Future;
use core::ops::Range;
use core::pin::pin;
use core::task::{Context, Poll, Waker};

use embedded_storage_async::nor_flash::NorFlash;
use flexarm_link::msg::{Param, SettingsRefusal};
use flexarm_link::params::PARAMS;
use sequential_storage::cache::{Cache, Uncached};
use sequential_storage::map::{MapConfig, MapStorage};

use crate::session::{Home, home};

/// The record's layout version: bumped when [`encode`]'s layout changes (2: a presence bitmap
/// in place of each value's index, so 24 parameters fit a 256-byte page's record).
pub const SCHEMA: u16 = 2;

/// The map's key of the settings record.
const KEY: u8 = 0;

/// The number of parameters (the link's declaration).
pub const COUNT: usize = PARAMS.len();

/// The longest record [bytes]: the header (layout, protocol, configuration hash, the bitmap of
/// the values held), every parameter's value, the CRC.
pub const MAX_RECORD: usize = 12 + COUNT * 4 + 4;

// The bitmap is one word.
const _: () = assert!(
    COUNT <= 32,
    "more parameters than the record's bitmap holds"
);

/// The map's work buffer [bytes]: a record and its key, rounded up to a word of 4 bytes.
pub const BUFFER: usize = (MAX_RECORD + 1).div_ceil(4) * 4;

/// Bitwise, as the link's frames (`flexarm_link::frame`): no 1 KiB table in flash.
const CRC: crc::Crc<u32, crc::NoTable> = crc::Crc::<u32, crc::NoTable>::new(&crc::CRC_32_ISO_HDLC);

/// The values of a save, one per parameter in the wire's order; NaN where the record holds
/// none (no `Set` accepts NaN). Compared bit for bit.
#[derive(Clone, Copy, Debug)]
pub struct Values(pub [f32; COUNT]);

impl PartialEq for Values {
    fn eq(&self, other: &Self) -> bool {
        self.0
            .iter()
            .zip(&other.0)
            .all(|(a, b)| a.to_bits() == b.to_bits())
    }
}

impl Values {
    /// No value.
    pub const fn none() -> Self {
        Self([f32::NAN; COUNT])
    }

    /// The value of parameter `i` (its index in the wire's order), if held.
    pub fn get(&self, i: usize) -> Option<f32> {
        self.0.get(i).copied().filter(|v| !v.is_nan())
    }

    /// Whether `p` is saved: every parameter a board's configuration holds, not the piezo
    /// bias (a bring-up aid that returns to 0 whenever the drive leaves holding).
    pub fn saved(p: Param) -> bool {
        home(p) != Home::Bias
    }
}

/// What boot found in the store.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Loaded {
    /// Nothing saved.
    Nothing,
    /// The settings were erased (`config erase`).
    Erased,
    /// Settings of this build: to be applied (each through a `Set`'s checks).
    Values(Values),
    /// Settings this build refuses.
    Refused(SettingsRefusal),
}

/// Why a save or an erase failed.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum StoreError {
    /// The flash reported an error (its driver's, or a power cut on the host's model).
    Flash,
    /// The store's contents are no store (an unformatted flash): an erase formats it.
    Corrupted,
    /// The crate reported another error (full, buffer, logic).
    Other,
}

/// Runs `f` to completion on this thread. The boards' flash drivers complete every operation
/// before they return, so no future of the store ever waits: each poll makes progress.
pub fn block_on<F: Future>(f: F) -> F::Output {
    let mut f = pin!(f);
    let mut cx = Context::from_waker(Waker::noop());
    loop {
        if let Poll::Ready(v) = f.as_mut().poll(&mut cx) {
            return v;
        }
    }
}

/// The record of `values`, saved by a build of configuration hash `params_hash`, into `out`;
/// its length.
pub fn encode(values: &Values, params_hash: u32, out: &mut [u8; MAX_RECORD]) -> usize {
    fn put(out: &mut [u8], n: &mut usize, bytes: &[u8]) {
        for &b in bytes {
            if let Some(o) = out.get_mut(*n) {
                *o = b;
            }
            *n += 1;
        }
    }
    let mut n = 0;
    put(out, &mut n, &SCHEMA.to_le_bytes());
    put(out, &mut n, &flexarm_link::VERSION.to_le_bytes());
    put(out, &mut n, &params_hash.to_le_bytes());
    let held = (0..COUNT)
        .filter(|&i| values.get(i).is_some())
        .fold(0u32, |m, i| m | 1 << i);
    put(out, &mut n, &held.to_le_bytes());
    for i in 0..COUNT {
        if let Some(v) = values.get(i) {
            put(out, &mut n, &v.to_le_bytes());
        }
    }
    let crc = CRC.checksum(out.get(..n).unwrap_or(&[]));
    put(out, &mut n, &crc.to_le_bytes());
    n
}

/// The values of a record saved for configuration hash `params_hash`, or why they are refused.
/// An empty record is an erase.
pub fn decode(record: &[u8], params_hash: u32) -> Loaded {
    if record.is_empty() {
        return Loaded::Erased;
    }
    let corrupt = Loaded::Refused(SettingsRefusal::Corrupt);
    let Some(split) = record.len().checked_sub(4) else {
        return corrupt;
    };
    let (body, crc) = record.split_at(split);
    let word = |b: &[u8]| -> Option<[u8; 4]> { b.try_into().ok() };
    let half = |b: &[u8]| -> Option<[u8; 2]> { b.try_into().ok() };
    if word(crc).map(u32::from_le_bytes) != Some(CRC.checksum(body)) {
        return corrupt;
    }
    let (Some(schema), Some(version), Some(hash), Some(held)) = (
        body.get(0..2).and_then(half).map(u16::from_le_bytes),
        body.get(2..4).and_then(half).map(u16::from_le_bytes),
        body.get(4..8).and_then(word).map(u32::from_le_bytes),
        body.get(8..12).and_then(word).map(u32::from_le_bytes),
    ) else {
        return corrupt;
    };
    if schema != SCHEMA || version != flexarm_link::VERSION {
        return Loaded::Refused(SettingsRefusal::Version);
    }
    if hash != params_hash {
        return Loaded::Refused(SettingsRefusal::Hash);
    }
    let items = body.get(12..).unwrap_or(&[]);
    if held >> COUNT != 0 || items.len() != held.count_ones() as usize * 4 {
        return corrupt;
    }
    let mut values = Values::none();
    let mut next = items.chunks_exact(4);
    for (i, slot) in values.0.iter_mut().enumerate() {
        if held & (1 << i) == 0 {
            continue;
        }
        let Some(v) = next.next().and_then(word).map(f32::from_le_bytes) else {
            return corrupt;
        };
        if v.is_nan() {
            return corrupt;
        }
        *slot = v;
    }
    Loaded::Values(values)
}

/// The settings store in `flash`'s pages `range` (absolute addresses of the flash driver, each
/// end on an erase page's boundary, at least two pages).
pub struct Store<F: NorFlash> {
    map: MapStorage<u8, F, Cache<Uncached, Uncached, Uncached, u8>>,
    /// The map's work buffer: here, not on the stack (the firmware keeps the store in a
    /// static; its idle task's stack is budgeted, `firmware/budgets.txt`).
    buf: [u8; BUFFER],
}

impl<F: NorFlash> Store<F> {
    /// The store over `range` of `flash`, or `None` when the range does not fit the map's
    /// rules (page boundaries, two pages at least).
    pub fn new(flash: F, range: Range<u32>) -> Option<Self> {
        let config = MapConfig::try_new(range).ok()?;
        Some(Self {
            map: MapStorage::new(flash, config, Cache::new_uncached()),
            buf: [0; BUFFER],
        })
    }

    /// The last complete record, read for a build of configuration hash `params_hash`.
    pub fn load(&mut self, params_hash: u32) -> Loaded {
        match block_on(self.map.fetch_item::<&[u8]>(&mut self.buf, &KEY)) {
            Ok(None) => Loaded::Nothing,
            Ok(Some(record)) => decode(record, params_hash),
            Err(_) => Loaded::Refused(SettingsRefusal::Unreadable),
        }
    }

    /// Saves `values` for a build of configuration hash `params_hash`: the previous record
    /// stays the one read until this one is complete.
    pub fn save(&mut self, values: &Values, params_hash: u32) -> Result<(), StoreError> {
        let mut record = [0u8; MAX_RECORD];
        let n = encode(values, params_hash, &mut record);
        self.put(record.get(..n).unwrap_or(&[]))
    }

    /// Marks the settings erased (an empty record, written as a save is); a store that cannot
    /// be read is formatted first (both pages erased).
    pub fn erase(&mut self) -> Result<(), StoreError> {
        match self.put(&[]) {
            Err(StoreError::Corrupted) => {
                block_on(self.map.erase_all()).map_err(error)?;
                self.put(&[])
            }
            r => r,
        }
    }

    /// Stores `record`.
    fn put(&mut self, record: &[u8]) -> Result<(), StoreError> {
        // Generic over the one value type, not through the crate's `dyn Value` (no indirect
        // call: scripts/fw-stack-bound follows every call of the firmware's idle task).
        block_on(self.map.store_item_generic(&mut self.buf, &KEY, &record)).map_err(error)
    }

    /// The flash driver back (the host's tests inspect it).
    pub fn into_flash(self) -> F {
        self.map.destroy().0
    }
}

fn error<E>(e: sequential_storage::Error<E>) -> StoreError {
    match e {
        sequential_storage::Error::Storage { .. } => StoreError::Flash,
        sequential_storage::Error::Corrupted { .. } => StoreError::Corrupted,
        _ => StoreError::Other,
    }
}

/// The flash error of the RAM-backed and register drivers: one kind, the operation failed.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct FlashError;

impl embedded_storage_async::nor_flash::NorFlashError for FlashError {
    fn kind(&self) -> embedded_storage_async::nor_flash::NorFlashErrorKind {
        embedded_storage_async::nor_flash::NorFlashErrorKind::Other
    }
}
