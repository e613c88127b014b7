//! mm-wave (radar, 76–81 GHz) properties of a material: the complex relative permittivity
//! `ε_r = ε' − jε''` (constant, ITU-R P.2040 fit, Cole–Cole, ITU-R P.840 water, frequency table,
//! conductor), coating layers over a half-space or a slab with its backing, and the reflection and
//! transmission of the whole stack from the Fresnel equations and the Airy recursion (Orfanidis,
//! *Electromagnetic Waves and Antennas*, ch. 6–7), with the Ament roughness factor.
//!
//! Fresnel coefficients follow the convention of physics.md §1.3 (stated in full in the
//! [`material`](super) module doc): `Γ_TE` is an E-field ratio, `Γ_TM` an H-field ratio, so
//! `Γ_TM(0) = −Γ_TE(0)` and a perfect conductor has `Γ_TE = −1`, `Γ_TM = +1`.

use std::f64::consts::PI;

use num_complex::Complex64;

use super::Polarisation;
use crate::constants::SPEED_OF_LIGHT_M_S;

/// Vacuum permittivity, F/m (CODATA 2018).
const EPS0: f64 = 8.854_187_812_8e-12;

/// One relaxation term of a Cole–Cole model: `Δε / (1 + (jωτ)^(1−α))`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ColeColeTerm {
    pub delta_eps: f64,
    pub tau_s: f64,
    pub alpha: f64,
}

/// A complex relative permittivity `ε' − jε''` as a function of frequency.
#[derive(Debug, Clone, PartialEq)]
pub enum Permittivity {
    /// Frequency-independent `ε' − jε''` (stores `ε'`, `ε''`).
    Constant { re: f64, loss: f64 },
    /// ITU-R P.2040 fit: `ε' = a f^b`, `σ = c f^d` (f in GHz), `ε'' = σ/(2πfε₀)`.
    ItuP2040 { a: f64, b: f64, c: f64, d: f64 },
    /// Liquid water, ITU-R P.840 double-Debye model (Liebe et al. 1991).
    Water { temperature_c: f64 },
    /// Cole–Cole relaxation model (Gabriel et al. 1996 for tissues).
    ColeCole {
        eps_inf: f64,
        sigma_s_per_m: f64,
        terms: Vec<ColeColeTerm>,
    },
    /// Tabulated `(f_GHz, ε', ε'')`, linear in frequency, held beyond the ends.
    Table(Vec<(f64, f64, f64)>),
    /// A conductor: `ε = 1 − jσ/(ωε₀)`.
    Conductor { sigma_s_per_m: f64 },
}

impl Permittivity {
    /// `ε_r = ε' − jε''` at `freq_hz`.
    pub fn eval(&self, freq_hz: f64) -> Complex64 {
        let omega = 2.0 * PI * freq_hz;
        match self {
            Permittivity::Constant { re, loss } => Complex64::new(*re, -loss),
            Permittivity::ItuP2040 { a, b, c, d } => {
                let f_ghz = freq_hz * 1e-9;
                let sigma = c * f_ghz.powf(*d);
                Complex64::new(a * f_ghz.powf(*b), -sigma / (omega * EPS0))
            }
            Permittivity::Water { temperature_c } => {
                water_permittivity_p840(freq_hz, *temperature_c)
            }
            Permittivity::ColeCole {
                eps_inf,
                sigma_s_per_m,
                terms,
            } => {
                let mut eps = Complex64::new(*eps_inf, -sigma_s_per_m / (omega * EPS0));
                for t in terms {
                    let jwt = Complex64::new(0.0, omega * t.tau_s);
                    eps += t.delta_eps / (1.0 + jwt.powf(1.0 - t.alpha));
                }
                eps
            }
            Permittivity::Table(rows) => {
                let f = freq_hz * 1e-9;
                let first = rows[0];
                let last = rows[rows.len() - 1];
                let (re, loss) = if f <= first.0 {
                    (first.1, first.2)
                } else if f >= last.0 {
                    (last.1, last.2)
                } else {
                    let i = rows.windows(2).position(|w| f <= w[1].0).unwrap_or(0);
                    let (a, b) = (rows[i], rows[i + 1]);
                    let t = (f - a.0) / (b.0 - a.0);
                    (a.1 + t * (b.1 - a.1), a.2 + t * (b.2 - a.2))
                };
                Complex64::new(re, -loss)
            }
            Permittivity::Conductor { sigma_s_per_m } => {
                Complex64::new(1.0, -sigma_s_per_m / (omega * EPS0))
            }
        }
    }
}

/// Complex permittivity of liquid water, ITU-R P.840 (eqs. for ε', ε'' after Liebe, Hufford & Manabe,
/// Int. J. Infrared Millim. Waves 12:659, 1991), returned as `ε' − jε''`.
pub fn water_permittivity_p840(freq_hz: f64, temperature_c: f64) -> Complex64 {
    let f = freq_hz * 1e-9;
    let theta = 300.0 / (temperature_c + 273.15);
    let e0 = 77.66 + 103.3 * (theta - 1.0);
    let e1 = 0.0671 * e0;
    let e2 = 3.52;
    let fp = 20.20 - 146.0 * (theta - 1.0) + 316.0 * (theta - 1.0) * (theta - 1.0);
    let fs = 39.8 * fp;
    let (xp, xs) = (f / fp, f / fs);
    let re = (e0 - e1) / (1.0 + xp * xp) + (e1 - e2) / (1.0 + xs * xs) + e2;
    let im = f * (e0 - e1) / (fp * (1.0 + xp * xp)) + f * (e1 - e2) / (fs * (1.0 + xs * xs));
    Complex64::new(re, -im)
}

/// One coating layer of a mm-wave stack.
#[derive(Debug, Clone, PartialEq)]
pub struct Layer {
    pub name: String,
    pub eps_r: Permittivity,
    pub thickness_m: f64,
    pub source: Option<String>,
}

/// What lies behind a slab.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Backing {
    Air,
    /// Perfect electric conductor.
    Pec,
}

/// mm-wave (radar) properties: `layers` (outermost first) over the bulk, which is a half-space or,
/// with `thickness_m`, a slab with `backing` behind.
#[derive(Debug, Clone, PartialEq)]
pub struct MmWave {
    /// Bulk permittivity (`None` for a perfect conductor).
    pub eps_r: Option<Permittivity>,
    /// Whether the bulk is a metal.
    pub conductor: bool,
    /// Slab thickness of the bulk, m (`None`: half-space).
    pub thickness_m: Option<f64>,
    pub backing: Backing,
    pub layers: Vec<Layer>,
    /// rms height of the top surface, m.
    pub roughness_m: f64,
    pub source: String,
}

/// Response of a mm-wave stack.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StackResponse {
    /// Reflection coefficient (TE: E-field ratio, TM: H-field ratio).
    pub gamma: Complex64,
    /// Amplitude of the tangential field transmitted into the back medium (0 into a conductor).
    pub t: Complex64,
    /// Reflected power fraction |Γ|².
    pub reflectance: f64,
    /// Power fraction transmitted into the back medium (the rest is absorbed in the layers).
    pub transmittance: f64,
}

/// Medium of a stack.
#[derive(Debug, Clone, Copy)]
enum Medium {
    Eps(Complex64),
    Pec,
}

/// Normalised z-wavenumber `√(ε − sin²θ)` on the decaying branch (Im ≤ 0 for `e^{−jkz}`).
fn nz(eps: Complex64, sin2: f64) -> Complex64 {
    let w = (eps - sin2).sqrt();
    if w.im > 0.0 || (w.im == 0.0 && w.re < 0.0) {
        -w
    } else {
        w
    }
}

/// Layers of a mm-wave stack handled without allocation.
const MAX_STACK: usize = 8;

/// Reflection and transmission of a plane wave from air at `incidence_rad` onto `layers`
/// (`(ε, thickness)`, outermost first) over the half-space `back` (Airy recursion; Orfanidis ch. 6–7).
fn stack_response(
    layers: &[(Complex64, f64)],
    back: Medium,
    freq_hz: f64,
    incidence_rad: f64,
    pol: Polarisation,
) -> StackResponse {
    let k0 = 2.0 * PI * freq_hz / SPEED_OF_LIGHT_M_S;
    let (sin_t, cos_t) = incidence_rad.sin_cos();
    let cos_t = cos_t.max(0.0);
    let sin2 = sin_t * sin_t;
    // Wave admittance normalised to the field whose reflection coefficient we track.
    let eta = |eps: Complex64| -> Complex64 {
        let z = nz(eps, sin2);
        match pol {
            Polarisation::Te => z,
            Polarisation::Tm => z / eps,
        }
    };
    let r = |a: Complex64, b: Medium| -> Complex64 {
        match b {
            Medium::Eps(eb) => {
                let eb = eta(eb);
                (a - eb) / (a + eb)
            }
            Medium::Pec => match pol {
                Polarisation::Te => Complex64::new(-1.0, 0.0),
                Polarisation::Tm => Complex64::new(1.0, 0.0),
            },
        }
    };
    let eta0 = Complex64::new(cos_t, 0.0);
    let n = layers.len();
    // gamma[i]: reflection coefficient at the front of medium i+1 (interface i), looking in.
    // gamma_p[i]: reflection coefficient of what lies behind interface i, referenced at interface i.
    // On the stack for the usual few layers (no allocation per ray).
    let zero = Complex64::new(0.0, 0.0);
    let (mut g_buf, mut gp_buf) = ([zero; MAX_STACK + 1], [zero; MAX_STACK + 1]);
    let (mut g_vec, mut gp_vec) = (Vec::new(), Vec::new());
    let (gamma, gamma_p): (&mut [Complex64], &mut [Complex64]) = if n <= MAX_STACK {
        (&mut g_buf[..=n], &mut gp_buf[..=n])
    } else {
        g_vec.resize(n + 1, zero);
        gp_vec.resize(n + 1, zero);
        (&mut g_vec, &mut gp_vec)
    };
    let eta_of = |i: usize| -> Complex64 { if i == 0 { eta0 } else { eta(layers[i - 1].0) } };
    // Interface n: between medium n (last layer or air) and the back.
    gamma[n] = r(eta_of(n), back);
    for i in (0..n).rev() {
        let (eps, d) = layers[i];
        let phase = Complex64::new(0.0, -2.0 * k0 * d) * nz(eps, sin2);
        gamma_p[i] = gamma[i + 1] * phase.exp();
        let ri = r(eta_of(i), Medium::Eps(eps));
        gamma[i] = (ri + gamma_p[i]) / (1.0 + ri * gamma_p[i]);
    }
    let g = gamma[0];
    // Forward tangential field through the stack: continuity at interface i gives
    // B_i = A_{i−1} (1 + Γ_i) / (1 + Γ'_{i+1}); then propagation across layer i.
    let mut a = Complex64::new(1.0, 0.0);
    for i in 0..n {
        let (eps, d) = layers[i];
        let b = a * (1.0 + gamma[i]) / (1.0 + gamma_p[i]);
        a = b * (Complex64::new(0.0, -k0 * d) * nz(eps, sin2)).exp();
    }
    let (t, transmittance) = match back {
        Medium::Pec => (Complex64::new(0.0, 0.0), 0.0),
        Medium::Eps(eb) => {
            let t = a * (1.0 + gamma[n]);
            let tr = if cos_t > 0.0 {
                t.norm_sqr() * eta(eb).re / eta0.re
            } else {
                0.0
            };
            (t, tr)
        }
    };
    StackResponse {
        gamma: g,
        t,
        reflectance: g.norm_sqr(),
        transmittance,
    }
}

/// Fresnel reflection coefficient of the interface air → half-space `ε` at `incidence_rad`
/// (physics.md §1.3 convention, see the `material` module doc).
pub fn fresnel_coefficient(eps: Complex64, incidence_rad: f64, pol: Polarisation) -> Complex64 {
    stack_response(&[], Medium::Eps(eps), 1e9, incidence_rad, pol).gamma
}

/// Ament roughness factor `exp(−2 (k σ_h cos θ)²)` on the coherent reflection coefficient
/// (Ament 1953; Beckmann & Spizzichino 1963).
pub fn ament_factor(freq_hz: f64, roughness_m: f64, incidence_rad: f64) -> f64 {
    let k = 2.0 * PI * freq_hz / SPEED_OF_LIGHT_M_S;
    let x = k * roughness_m * incidence_rad.cos();
    (-2.0 * x * x).exp()
}

impl MmWave {
    fn bulk_medium(&self, freq_hz: f64) -> Medium {
        match (&self.eps_r, self.conductor) {
            (Some(e), _) => Medium::Eps(e.eval(freq_hz)),
            (None, true) => Medium::Pec,
            (None, false) => Medium::Eps(Complex64::new(1.0, 0.0)),
        }
    }

    /// The full response of the stack (layers, bulk, backing) without roughness.
    pub fn response(&self, freq_hz: f64, incidence_rad: f64, pol: Polarisation) -> StackResponse {
        let n = self.layers.len() + 1;
        let zero = (Complex64::new(0.0, 0.0), 0.0);
        let mut buf = [zero; MAX_STACK + 1];
        let mut heap = Vec::new();
        let layers: &mut [(Complex64, f64)] = if n <= buf.len() {
            &mut buf[..n]
        } else {
            heap.resize(n, zero);
            &mut heap
        };
        for (slot, l) in layers.iter_mut().zip(&self.layers) {
            *slot = (l.eps_r.eval(freq_hz), l.thickness_m);
        }
        let coats = self.layers.len();
        let (stack, back) = match (self.thickness_m, self.bulk_medium(freq_hz)) {
            (Some(d), Medium::Eps(e)) => {
                layers[coats] = (e, d);
                let back = match self.backing {
                    Backing::Air => Medium::Eps(Complex64::new(1.0, 0.0)),
                    Backing::Pec => Medium::Pec,
                };
                (&layers[..], back)
            }
            (_, bulk) => (&layers[..coats], bulk),
        };
        stack_response(stack, back, freq_hz, incidence_rad, pol)
    }

    /// Whether waves pass through (a slab with air behind).
    pub fn is_slab(&self) -> bool {
        self.thickness_m.is_some() && self.backing == Backing::Air && self.eps_r.is_some()
    }
}
