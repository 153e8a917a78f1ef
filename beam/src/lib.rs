//! # flexarm-beam
//!
//! Host-side design tools for link 2 of the flexarm: the exact modes of the segmented beam with
//! the piezo patch (Eqs. 1–4), the closed modal loop of the piezo rate feedback and its
//! dissipated energy (Eqs. 21–33), and the objective at one design point (Eq. 34). The search
//! over the points (Eq. 35), its command and figures are the `flexarm-placement` crate's.
//! `docs/optimization.md` states every choice made where the paper is silent.
#![deny(clippy::unwrap_used, clippy::expect_used, clippy::panic)]

pub mod config;
pub mod design;
pub mod fem;
pub mod fragment;
pub mod lyapunov;
pub mod point;
pub mod section;
pub mod segmented;
pub mod toml_at;
