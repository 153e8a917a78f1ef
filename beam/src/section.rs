//! Cross sections of link 2: the bare beam and the three-layer composite under the patch.
//!
//! The patched section stacks, bottom to top, the PVDF film (sensor), the beam and the
//! piezoceramic (actuator), all of width `b`. Its flexural rigidity is taken about its own
//! modulus-weighted neutral axis (notes §2):
//! `z_n = Σ E_i t_i z_i / Σ E_i t_i`, `EI = b Σ E_i (t_i³/12 + t_i (z_i − z_n)²)`,
//! with `z_i` the mid-plane height of layer `i` above the bottom face. Its mass per length is
//! `ρA = b Σ ρ_i t_i`. Bonding layers are neglected (perfect bond, zero thickness).

use flexarm_core::control::piezo::PiezoMaterial;

/// Material and section data of the beam and both piezo layers, with the densities the core's
/// [`PiezoMaterial`] does not carry (SI units).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Layers {
    /// Moduli, thicknesses, width and piezo constants (the paper's table by default).
    pub material: PiezoMaterial<f64>,
    /// Beam density `ρ_b` [kg/m³] (not in the paper; aluminium 2700 by default).
    pub rho_b: f64,
    /// Ceramic density `ρ_c` [kg/m³] (the paper's `ρ_p = 7700`).
    pub rho_c: f64,
    /// Film density `ρ_f` [kg/m³] (the paper's 1780).
    pub rho_f: f64,
}

impl Default for Layers {
    fn default() -> Self {
        Self {
            material: PiezoMaterial::default(),
            rho_b: 2700.0,
            rho_c: 7700.0,
            rho_f: 1780.0,
        }
    }
}

/// Flexural rigidity and mass per length of one section.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Section {
    /// `EI` [N·m²].
    pub ei: f64,
    /// `ρA` [kg/m].
    pub rho_a: f64,
}

impl Layers {
    /// The bare beam: `EI = E_b b t_b³/12`, `ρA = ρ_b b t_b`.
    pub fn bare(&self) -> Section {
        let m = &self.material;
        Section {
            ei: m.e_b * m.b * m.t_b.powi(3) / 12.0,
            rho_a: self.rho_b * m.b * m.t_b,
        }
    }

    /// Height of the composite's neutral axis above the film's bottom face [m]: the core's
    /// [`PiezoMaterial::neutral_axis`], the axis the transducer constants are taken about.
    pub fn neutral_axis(&self) -> f64 {
        self.material.neutral_axis()
    }

    /// The patched section: film + beam + ceramic about the composite neutral axis.
    pub fn patched(&self) -> Section {
        let b = self.material.b;
        let zn = self.neutral_axis();
        let (ei, rho_a) = self
            .stack()
            .iter()
            .fold((0.0, 0.0), |(ei, ra), &(e, t, z, rho)| {
                (
                    ei + e * b * (t.powi(3) / 12.0 + t * (z - zn).powi(2)),
                    ra + rho * b * t,
                )
            });
        Section { ei, rho_a }
    }

    /// `(E, t, mid-plane height, ρ)` of film, beam and ceramic, bottom to top.
    fn stack(&self) -> [(f64, f64, f64, f64); 3] {
        let m = &self.material;
        [
            (m.e_f, m.t_f, m.t_f / 2.0, self.rho_f),
            (m.e_b, m.t_b, m.t_f + m.t_b / 2.0, self.rho_b),
            (m.e_c, m.t_c, m.t_f + m.t_b + m.t_c / 2.0, self.rho_c),
        ]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn symmetric_stack_has_centred_axis_and_parallel_axis_rigidity() {
        // Ceramic and film replaced by beam material of the beam's thickness: a solid beam of
        // thickness 3 t_b (plus nothing else), whose EI is E b (3 t)³ / 12.
        let mut l = Layers::default();
        let t = l.material.t_b;
        l.material.e_c = l.material.e_b;
        l.material.e_f = l.material.e_b;
        l.material.t_c = t;
        l.material.t_f = t;
        l.rho_c = l.rho_b;
        l.rho_f = l.rho_b;
        assert!((l.neutral_axis() - 1.5 * t).abs() < 1e-15);
        let p = l.patched();
        let solid = l.material.e_b * l.material.b * (3.0 * t).powi(3) / 12.0;
        assert!((p.ei / solid - 1.0).abs() < 1e-12);
        assert!((p.rho_a / (3.0 * l.bare().rho_a) - 1.0).abs() < 1e-12);
    }

    #[test]
    fn paper_patch_stiffens_and_loads() {
        let l = Layers::default();
        let (b, p) = (l.bare(), l.patched());
        // Ceramic of the beam's thickness and nearly its modulus: EI grows roughly eightfold.
        assert!(p.ei / b.ei > 6.0 && p.ei / b.ei < 9.0, "{}", p.ei / b.ei);
        assert!(p.rho_a / b.rho_a > 3.5 && p.rho_a / b.rho_a < 4.5);
        // The neutral axis moves up towards the ceramic.
        assert!(l.neutral_axis() > l.material.t_f + l.material.t_b / 2.0);
    }
}
