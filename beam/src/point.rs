//! One design point `(x_a, l_a, k_c)`: the objective `J` of Eq. 34 and everything known there
//! (the energies of Eqs. 21–33, the patch's modes). The search over the points is the
//! placement crate's (`flexarm-placement`); the firmware's parameters and the truth plant
//! evaluate single points here.

use crate::design::{DesignModel, Energy, PatchModes, Weights};

/// A design point with everything known about it.
#[derive(Clone, Debug, PartialEq)]
pub struct Optimum {
    /// Patch start [m].
    pub x_a: f64,
    /// Patch length [m].
    pub l_a: f64,
    /// Gain [s].
    pub k_c: f64,
    /// Objective `J`.
    pub j: f64,
    /// Dissipated energy `J0` and initial energy `W0`.
    pub energy: Energy,
    /// Modes and coupling at the patch.
    pub modes: PatchModes,
}

/// `J` and everything else at one design point; `None` if infeasible or not solvable.
pub fn evaluate(model: &DesignModel, w: &Weights, x_a: f64, l_a: f64, k_c: f64) -> Option<Optimum> {
    let pm = model.patch_modes(x_a, l_a).ok()?;
    evaluate_modes(model, w, pm, k_c)
}

/// [`evaluate`] with the patch's modes already solved.
pub fn evaluate_modes(
    model: &DesignModel,
    w: &Weights,
    pm: PatchModes,
    k_c: f64,
) -> Option<Optimum> {
    let e = model.energy(&pm, k_c)?;
    let j = w.objective(pm.l_a, k_c, &e);
    j.is_finite().then_some(Optimum {
        x_a: pm.x_a,
        l_a: pm.l_a,
        k_c,
        j,
        energy: e,
        modes: pm,
    })
}
