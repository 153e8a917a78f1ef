//! # flexarm-placement
//!
//! The placement optimization of the piezo patch on link 2 (Eqs. 34–35): the full grid over
//! `(x_a, l_a, k_c)` in parallel, the bounded pattern search from its best point, the
//! `optimize` command's run (its files and report) and its SVG figures. The physics of one
//! design point (the segmented beam's modes, the energies of Eqs. 21–33, the objective) is
//! `flexarm-beam`'s; only the simulator's binary depends on this crate.
//! `docs/optimization.md` states every choice made where the paper is silent.
#![deny(clippy::unwrap_used, clippy::expect_used, clippy::panic)]

pub mod cli;
pub mod optimize;
pub mod plot;
