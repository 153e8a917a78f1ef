//! The settings store (`flexarm_machine::store`) against a NOR-flash model with a power cut at
//! every word written and every page erased: after each cut, the next boot reads either the
//! previous complete settings or the new ones, never a mix, and never panics; and the store
//! keeps working (a save after the cut is read back).
//!
//! The model: pages erase to 0xFF; a word (4 bytes) is programmed once after an erase and only
//! turns 1s to 0s (a second program of a word is an error, as on a flash with ECC: stricter
//! than the STM32F405's); a cut program leaves half of the word's 1→0 transitions done; a cut
//! erase leaves the page's first half erased and the rest as it was with every other word's low
//! half cleared (a torn erase); after the cut every operation fails until the "reboot".

use embedded_storage_async::nor_flash::{ErrorType, NorFlash, ReadNorFlash};
use flexarm_link::msg::{Param, SettingsRefusal};
use flexarm_machine::store::{
    BUFFER, COUNT, FlashError, Loaded, MAX_RECORD, SCHEMA, Store, Values, decode, encode,
};

const PAGE: usize = 256;
const PAGES: usize = 2;
const HASH: u32 = 0x5b0e_89e3;

/// A NOR flash of `PAGES` pages of `PAGE` bytes, with a power cut after `budget` operations.
#[derive(Clone)]
struct Nor {
    mem: Vec<u8>,
    /// Operations (word programs, page erases) left before the cut; `None`: no cut.
    budget: Option<usize>,
    cut: bool,
    ops: usize,
}

impl Nor {
    fn new() -> Self {
        Self {
            mem: vec![0xFF; PAGE * PAGES],
            budget: None,
            cut: false,
            ops: 0,
        }
    }

    /// One more operation; `false` when the power is cut at (or before) it.
    fn spend(&mut self) -> bool {
        if self.cut {
            return false;
        }
        self.ops += 1;
        match self.budget {
            Some(0) => {
                self.cut = true;
                false
            }
            Some(ref mut n) => {
                *n -= 1;
                true
            }
            None => true,
        }
    }

    /// Power back: every operation works again (a reboot).
    fn reboot(&mut self) {
        self.budget = None;
        self.cut = false;
    }
}

impl ErrorType for Nor {
    type Error = FlashError;
}

impl ReadNorFlash for Nor {
    const READ_SIZE: usize = 1;
    async fn read(&mut self, offset: u32, bytes: &mut [u8]) -> Result<(), FlashError> {
        if self.cut {
            return Err(FlashError);
        }
        let o = offset as usize;
        let src = self.mem.get(o..o + bytes.len()).ok_or(FlashError)?;
        bytes.copy_from_slice(src);
        Ok(())
    }
    fn capacity(&self) -> usize {
        self.mem.len()
    }
}

impl NorFlash for Nor {
    const WRITE_SIZE: usize = 4;
    const ERASE_SIZE: usize = PAGE;
    async fn erase(&mut self, from: u32, to: u32) -> Result<(), FlashError> {
        assert_eq!(from as usize % PAGE, 0);
        assert_eq!(to as usize % PAGE, 0);
        for page in (from as usize..to as usize).step_by(PAGE) {
            if !self.spend() {
                if !self.cut {
                    return Err(FlashError);
                }
                // Torn: the first half erased, the rest scrambled.
                let p = &mut self.mem[page..page + PAGE];
                p[..PAGE / 2].fill(0xFF);
                for (i, b) in p[PAGE / 2..].iter_mut().enumerate() {
                    if i % 8 < 2 {
                        *b &= 0xF0;
                    }
                }
                return Err(FlashError);
            }
            self.mem[page..page + PAGE].fill(0xFF);
        }
        Ok(())
    }
    async fn write(&mut self, offset: u32, bytes: &[u8]) -> Result<(), FlashError> {
        let o = offset as usize;
        assert_eq!(o % 4, 0, "unaligned program");
        assert_eq!(bytes.len() % 4, 0, "partial word");
        for (k, w) in bytes.chunks_exact(4).enumerate() {
            let at = o + 4 * k;
            let old: [u8; 4] = self.mem[at..at + 4].try_into().unwrap();
            let cut = !self.spend();
            if old != [0xFF; 4] {
                panic!("a word programmed twice at {at:#x}");
            }
            for i in 0..4 {
                let new = old[i] & w[i];
                // A cut program: only half of the byte's 1→0 transitions happen.
                self.mem[at + i] = if cut { old[i] & (new | 0x0F) } else { new };
            }
            if cut {
                return Err(FlashError);
            }
        }
        Ok(())
    }
}

/// A distinct set of values: every saved parameter, from `seed`.
fn values(seed: u32) -> Values {
    let mut v = Values::none();
    for (i, slot) in v.0.iter_mut().enumerate() {
        let p = flexarm_link::params::PARAMS[i].param;
        if Values::saved(p) {
            *slot = seed as f32 + i as f32 * 0.25;
        }
    }
    v
}

fn store(nor: Nor) -> Store<Nor> {
    Store::new(nor, 0..(PAGE * PAGES) as u32).expect("two pages")
}

/// The record round-trips and refuses another build's.
#[test]
fn the_record_round_trips_and_names_what_it_refuses() {
    let v = values(7);
    let mut r = [0u8; MAX_RECORD];
    let n = encode(&v, HASH, &mut r);
    assert!(n <= MAX_RECORD && MAX_RECORD < BUFFER);
    assert_eq!(decode(&r[..n], HASH), Loaded::Values(v));
    assert_eq!(
        decode(&r[..n], HASH ^ 1),
        Loaded::Refused(SettingsRefusal::Hash)
    );
    // Any single bit flipped: refused, never other values.
    for bit in 0..n * 8 {
        let mut c = r;
        c[bit / 8] ^= 1 << (bit % 8);
        assert!(
            matches!(decode(&c[..n], HASH), Loaded::Refused(_)),
            "bit {bit}"
        );
    }
    // Another schema, its CRC recomputed: refused as a version.
    let mut c = r;
    c[0..2].copy_from_slice(&(SCHEMA + 1).to_le_bytes());
    let crc = crc::Crc::<u32>::new(&crc::CRC_32_ISO_HDLC).checksum(&c[..n - 4]);
    c[n - 4..n].copy_from_slice(&crc.to_le_bytes());
    assert_eq!(
        decode(&c[..n], HASH),
        Loaded::Refused(SettingsRefusal::Version)
    );
    assert_eq!(decode(&[], HASH), Loaded::Erased);
    assert_eq!(COUNT, flexarm_link::params::PARAMS.len());
    assert_eq!(values(1).get(Param::VaBias as usize), None);
}

/// Saves, an erase and saves again, read back each time, across page turns.
#[test]
fn saves_are_read_back_across_page_turns() {
    let mut s = store(Nor::new());
    assert_eq!(s.load(HASH), Loaded::Nothing);
    for i in 0..40 {
        s.save(&values(i), HASH).unwrap();
        assert_eq!(s.load(HASH), Loaded::Values(values(i)), "save {i}");
    }
    s.erase().unwrap();
    assert_eq!(s.load(HASH), Loaded::Erased);
    s.save(&values(99), HASH).unwrap();
    assert_eq!(s.load(HASH), Loaded::Values(values(99)));
    let erases = s.into_flash().ops;
    assert!(erases > 40, "{erases} operations");
}

/// An unformatted flash (not erased) gives no values; an erase formats it.
#[test]
fn an_unformatted_flash_is_refused_and_formatted_by_an_erase() {
    let mut nor = Nor::new();
    nor.mem
        .iter_mut()
        .enumerate()
        .for_each(|(i, b)| *b = i as u8);
    let mut s = store(nor);
    // The crate reads such pages as empty or corrupted: never values.
    let read = s.load(HASH);
    assert!(
        matches!(
            read,
            Loaded::Nothing | Loaded::Refused(SettingsRefusal::Unreadable)
        ),
        "{read:?}"
    );
    s.erase().unwrap();
    assert_eq!(s.load(HASH), Loaded::Erased);
    s.save(&values(3), HASH).unwrap();
    assert_eq!(s.load(HASH), Loaded::Values(values(3)));
}

/// What the store reads at boot after the power was cut during one operation.
enum Op {
    Save(u32),
    Erase,
}

/// For each of `history`'s operations in turn, a power cut at every one of its flash operations:
/// the boot after reads the state before the operation or after it, and a save then works.
fn cut_everywhere(history: &[Op]) -> usize {
    let mut nor = Nor::new();
    let mut before = Loaded::Nothing;
    let mut cuts = 0;
    for op in history {
        let after = match op {
            Op::Save(i) => Loaded::Values(values(*i)),
            Op::Erase => Loaded::Erased,
        };
        let run = |s: &mut Store<Nor>| match op {
            Op::Save(i) => s.save(&values(*i), HASH),
            Op::Erase => s.erase(),
        };
        // Its length in flash operations, uncut.
        let mut whole = store(nor.clone());
        let start = nor.ops;
        run(&mut whole).unwrap();
        let whole = whole.into_flash();
        let length = whole.ops - start;
        for k in 0..=length {
            let mut cut = nor.clone();
            cut.budget = Some(k);
            let mut s = store(cut);
            let r = run(&mut s);
            let mut flash = s.into_flash();
            assert_eq!(r.is_ok(), !flash.cut, "cut at {k} of {length}");
            flash.reboot();
            let mut boot = store(flash);
            let read = boot.load(HASH);
            assert!(
                read == before || read == after,
                "cut at {k} of {length}: {read:?}, neither {before:?} nor {after:?}"
            );
            // The store still works: a save after the cut is read back.
            boot.save(&values(1000), HASH)
                .unwrap_or_else(|e| panic!("cut at {k}: save after it: {e:?}"));
            assert_eq!(boot.load(HASH), Loaded::Values(values(1000)));
            cuts += 1;
        }
        nor = whole;
        before = after;
    }
    cuts
}

/// Twelve saves (they fill a page and turn to the other several times), an erase and a save:
/// a cut at every word and every erase of each.
#[test]
fn a_power_cut_at_any_write_or_erase_leaves_old_or_new_settings() {
    let mut history: Vec<Op> = (0..12).map(Op::Save).collect();
    history.push(Op::Erase);
    history.push(Op::Save(50));
    let cuts = cut_everywhere(&history);
    println!("{cuts} power cuts");
    assert!(cuts > 14 * 30, "{cuts}");
}
