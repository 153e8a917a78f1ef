//! The firmware's PLL dividers (`firmware/src/board/pll.rs`, compiled here as it is on the
//! board): every crystal that is a whole number of MHz from 4 to 26 gives exactly 168 MHz and
//! 48 MHz within RM0090's limits, and what no setting can serve is refused with the constraint.

#[allow(dead_code)]
#[path = "../../firmware/src/board/pll.rs"]
mod pll;

use pll::{CLK48_HZ, HSI_HZ, Pll, SYSCLK_HZ, pll_for, pll_for_hse};

/// RM0090's limits (RCC_PLLCFGR), and the two output frequencies exact.
fn check(input_hz: u32, p: Pll) {
    let f = u64::from(input_hz);
    let (m, n, pp, q) = (
        u64::from(p.m),
        u64::from(p.n),
        u64::from(p.p),
        u64::from(p.q),
    );
    assert!((2..=63).contains(&m), "{input_hz}: M {m}");
    assert!(
        f >= 1_000_000 * m && f <= 2_000_000 * m,
        "{input_hz}: VCO input {} Hz",
        f / m
    );
    assert!((50..=432).contains(&n), "{input_hz}: N {n}");
    let vco_times_m = f * n;
    assert!(
        vco_times_m >= 100_000_000 * m && vco_times_m <= 432_000_000 * m,
        "{input_hz}: VCO {} Hz",
        vco_times_m / m
    );
    assert!([2, 4, 6, 8].contains(&pp), "{input_hz}: P {pp}");
    assert!((2..=15).contains(&q), "{input_hz}: Q {q}");
    assert_eq!(f * n, u64::from(SYSCLK_HZ) * m * pp, "{input_hz}: SYSCLK");
    assert_eq!(f * n, u64::from(CLK48_HZ) * m * q, "{input_hz}: 48 MHz");
    // PLLCFGR's fields read back.
    let r = p.pllcfgr();
    assert_eq!(u64::from(r & 0x3F), m);
    assert_eq!(u64::from((r >> 6) & 0x1FF), n);
    assert_eq!(u64::from(((r >> 16) & 0b11) * 2 + 2), pp);
    assert_eq!(u64::from((r >> 24) & 0xF), q);
    assert_eq!(r & (1 << 22), 0, "PLLSRC is the caller's");
}

#[test]
fn every_whole_mhz_crystal_from_4_to_26_gives_168_and_48_mhz() {
    for mhz in 4..=26 {
        let hz = mhz * 1_000_000;
        let p = pll_for_hse(hz).unwrap_or_else(|e| panic!("{mhz} MHz: {e}"));
        check(hz, p);
        // The least jitter: the highest VCO input that serves, 2 MHz for an even crystal.
        if mhz % 2 == 0 {
            assert_eq!(hz / p.m, 2_000_000, "{mhz} MHz");
        }
    }
    // The board's 8 MHz crystal and the internal oscillator's fallback, as RM0090's examples.
    assert_eq!(
        pll_for_hse(8_000_000),
        Ok(Pll {
            m: 4,
            n: 168,
            p: 2,
            q: 7
        })
    );
    assert_eq!(
        pll_for(HSI_HZ),
        Ok(Pll {
            m: 8,
            n: 168,
            p: 2,
            q: 7
        })
    );
    // 25 MHz (odd: 1 MHz into the VCO is the only input that divides 168 and 48 MHz exactly).
    assert_eq!(
        pll_for_hse(25_000_000),
        Ok(Pll {
            m: 25,
            n: 336,
            p: 2,
            q: 7
        })
    );
}

#[test]
fn what_no_setting_serves_is_refused_with_its_constraint() {
    for hz in [3_000_000, 27_000_000, 0] {
        let e = pll_for_hse(hz).unwrap_err();
        assert!(e.contains("4 to 26 MHz"), "{hz}: {e}");
    }
    // In the HSE range, but 168 MHz and 48 MHz cannot both be exact from it.
    for hz in [12_500_000, 4_100_000, 25_000_001] {
        let e = pll_for_hse(hz).unwrap_err();
        assert!(
            e.contains("RM0090, RCC_PLLCFGR") && e.contains("168 MHz and 48 MHz"),
            "{hz}: {e}"
        );
    }
}
