//! Estimation of every CFAR hit: a second `impl` block of [`RadarChain`] (the waveform side is in
//! `baseband.rs`, the CFAR in `cfar.rs`). Per hit, in parallel: range and Doppler by parabolic
//! interpolation of ln P, the TDM-MIMO Doppler-ambiguity hypothesis test, the angle fit of one or
//! more targets per range-Doppler cell (CLEAN / RELAX, then a joint Gauss-Newton refinement),
//! elevation from matched sub-apertures, the angle gate, power and SNR, and the ground-truth
//! object of the detection.
//!
//! # Angle gate
//! A detection is reported only when its estimated direction lies inside the gate = declared field
//! of view ∩ two-way main lobe of the Tx / Rx patterns
//! ([`crate::radar::antenna::Antennas::main_lobe_rad`]; `ProcessingConfig::field_of_view_gate`),
//! after the sines are folded into the array's unambiguous interval (period 2/g in sin-space, g the
//! greatest common divisor of the virtual element offsets in λ/2). Outside the gate an estimate
//! cannot be told from a sidelobe, grating-lobe or multipath-corrupted one (a single λ/2 vertical
//! baseline puts a noisy or two-ray-corrupted elevation anywhere in ±90°), and the RCS estimate
//! would divide by a gain that is not the main lobe's. Before the angle fit, the TDM-MIMO Doppler
//! ambiguity is resolved ([`super::ProcessingConfig::velocity_disambiguation`]): with the folded
//! range rate a target beyond ±v_max (every static object seen from a car faster than 37 km/h with
//! the default waveform) gets Tx-slot phase errors 2π j t / N_tx that move its angle estimate by
//! tens of degrees.
//!
//! # Cost
//! The joint fit evaluates its least-squares cost tens of times per hit (imaging preset: ≈ 80
//! evaluations, ≈ 150 steering vectors per CFAR hit over 192 channels), so its kernels are
//! written for that: channel vectors as separate real and imaginary arrays with dot products over
//! eight partial sums per term (AVX2 + FMA where available), steering vectors from per-axis
//! phasors planned per array ([`SteerPlan`]: a filled row is one run of products, a row at z = 0
//! a copy, the elevation phasors kept while s_z stays), the forward-difference Jacobian reusing
//! the Gram matrix of the unperturbed set (only the perturbed row and column change). The same
//! algorithm as before, to rounding (≲ 1e-9 rad in the angles of `osiris bench radar`'s paths).

use num_complex::Complex64;
use rayon::prelude::*;

use crate::constants::SPEED_OF_LIGHT_M_S;
use crate::radar::baseband::{C32, ChainDetection, RadarChain};
use crate::radar::processing::{self, MAX_ANGLE_PEAKS};

/// Re-estimation sweeps over all components after each new angle component (RELAX).
const RELAX_SWEEPS: usize = 1;

/// Gauss-Newton iterations (at most) of the joint azimuth refinement.
const JOINT_ITERATIONS: usize = 12;

/// The representative of `s` in `[−period/2, period/2)` (`None`: `s` itself).
fn principal(s: f64, period: Option<f64>) -> f64 {
    match period {
        Some(p) => s - p * (s / p + 0.5).floor(),
        None => s,
    }
}

impl RadarChain {
    /// Interpolation, angle, power, SNR and object id of every CFAR hit (hits in parallel).
    pub(in crate::radar) fn estimate(&mut self, out: &mut Vec<ChainDetection>) {
        let start = out.len();
        // Paths by range bin, for the object-id look-up.
        let dv = self.lambda_m / (2.0 * self.nc as f64 * self.t_rep_s);
        let bins_per_hz = self.ns as f64 / self.fs_hz;
        self.path_bins.clear();
        self.path_bins.extend(
            self.paths
                .iter()
                .enumerate()
                .map(|(i, p)| (p.beat_hz * bins_per_hz, p.range_rate_m_s / dv, i as u32)),
        );
        self.path_bins.sort_by(|a, b| a.0.total_cmp(&b.0));
        let hits = std::mem::take(&mut self.hits);
        let mut dets = std::mem::take(&mut self.dets);
        let this = &*self;
        hits.par_iter()
            .map_init(
                || this.angle_bufs(),
                |b, &(n, d)| this.estimate_one(n, d, b),
            )
            .collect_into_vec(&mut dets);
        out.extend(dets.iter().flatten().flatten());
        self.hits = hits;
        self.dets = dets;
        let max = self.proc.max_detections;
        if out.len() - start > max {
            out[start..].sort_by(|a, b| b.power_dbm.total_cmp(&a.power_dbm));
            out.truncate(start + max);
        }
    }

    fn angle_bufs(&self) -> AngleBufs {
        let nk = self.nk;
        AngleBufs {
            line: vec![C32::default(); self.az_len],
            scratch: vec![C32::default(); self.fft_az.get_inplace_scratch_len()],
            x: Split::zeros(nk),
            d: Split::zeros(nk),
            steer: Split::zeros(MAX_ANGLE_PEAKS * nk),
            rows: vec![Complex64::default(); self.el_rows.len()],
            tmp: Split::zeros(nk),
            r: Split::zeros(nk),
            r0: Split::zeros(nk),
            jac: Split::zeros(MAX_ANGLE_PEAKS * nk),
            pow_y: Split::zeros(self.steer_plan.len[0]),
            pow_z: vec![AxisPowers::new(self.steer_plan.len[1]); MAX_ANGLE_PEAKS],
            el_val: Split::zeros(self.el_steer_re.len() / self.el_rows.len().max(1)),
            gram: Gram::default(),
        }
    }

    /// One CFAR hit at range bin `n`, Doppler bin `d` → up to `max_angle_peaks_per_cell`
    /// detections, one per resolved angle component (none below `min_snr_db`, none outside the
    /// angle gate). The cell's channel vector is compensated with the range rate the TDM
    /// hypothesis test picks ([`Self::disambiguate_velocity`]).
    ///
    /// Several targets in one cell (same range and Doppler) are separated in angle by a
    /// sequential fit (CLEAN / RELAX: Li & Stoica, "Efficient mixed-spectrum estimation with
    /// applications to target feature extraction", IEEE Trans. SP 44(2), 1996): the strongest
    /// peak of the zero-padded azimuth spectrum gives a component (interpolated azimuth sine,
    /// elevation, least-squares amplitude); its steering vector is subtracted and the residual's
    /// spectrum gives the next candidate (each existing component is then re-fitted once within
    /// half a resolution cell of its position, the others subtracted). Candidates stop when one
    /// fails (a) or (b) below or lies within half a cell of a component. The complete set is then
    /// refined jointly (Gauss-Newton on the variable-projection cost, [`Self::refine_jointly`]:
    /// close, in-phase targets bias a one-at-a-time fit by up to a few degrees) and accepted when
    /// every component but the strongest (a) has a beam power within
    /// `angle_peak_dynamic_range_db` of the strongest, (b) clears both `min_snr_db` and the
    /// noise-referred threshold `ln(1/P_FA)` (a noise-only beam output is exponential:
    /// P(|b|² > T σ²) = e^{−T}; `P_FA` of the CFAR), (c) lies at least one angular resolution
    /// cell from every other component (main-lobe half width: 2/N_az in sin-space for the
    /// rectangular window, 4/N_az for Hann, N_az the horizontal aperture in λ/2); otherwise the
    /// failing component is dropped (the weakest below (a) or (b), else the weaker of the closest
    /// pair) and the rest refined again. Candidates are the strongest local maxima of the
    /// residual spectrum at least one resolution cell from every component (the refinement keeps
    /// them half a cell apart): on an extended target (a car's side, a continuum of scatterers)
    /// the residual peaks next to the components and a free fit pulls them together; dropping
    /// the weakest of the whole set then removed resolved components too (a car at 50 m kept one
    /// angle per cell of the four the fit found). Subtracting the fitted components
    /// removes their window sidelobes, so sidelobes never become detections (the rectangular
    /// window's −13 dB sidelobes lie within the default 15 dB dynamic range and 1.5 cells from
    /// the main lobe: a plain local-maximum search would report them).
    // Small dense linear algebra over component indices: index loops are the clearest form.
    #[allow(clippy::needless_range_loop)]
    fn estimate_one(
        &self,
        n: usize,
        d: usize,
        b: &mut AngleBufs,
    ) -> [Option<ChainDetection>; MAX_ANGLE_PEAKS] {
        let mut res = [None; MAX_ANGLE_PEAKS];
        let (ns, nc, nk) = (self.ns, self.nc, self.nk);
        let dv = self.lambda_m / (2.0 * nc as f64 * self.t_rep_s);
        let p = &self.power;
        let ln = |v: f32| (v.max(1e-38) as f64).ln();
        let v0 = p[n * nc + d];
        // Gaussian (parabolic in ln P) interpolation in range and Doppler.
        let (dn, lr) = if n > 0 && n + 1 < ns {
            processing::parabolic_peak(ln(p[(n - 1) * nc + d]), ln(v0), ln(p[(n + 1) * nc + d]))
        } else {
            (0.0, ln(v0))
        };
        let (dd, ld) = processing::parabolic_peak(
            ln(p[n * nc + (d + nc - 1) % nc]),
            ln(v0),
            ln(p[n * nc + (d + 1) % nc]),
        );
        let peak = (lr + ld - ln(v0)).exp();
        let d_signed = if d >= nc / 2 {
            d as f64 - nc as f64
        } else {
            d as f64
        };
        // Range rate of the Doppler bin (folded into ±v_max), then unfolded by the TDM hypothesis
        // test; `b.x` holds the cell's channel vector compensated with it.
        let v = if self.disambiguate {
            self.disambiguate_velocity(n, d, (d_signed + dd) * dv, b)
        } else {
            let v = (d_signed + dd) * dv;
            self.load_cell(n, d, v, b);
            v
        };
        let fb = (n as f64 + dn) * self.fs_hz / ns as f64;
        let range = SPEED_OF_LIGHT_M_S * (fb - 2.0 * v / self.lambda_m) / (2.0 * self.slope);
        let noise_beam = self.noise_cell * self.angle_win_sq;
        let snr_db_of = |beam: f64| 10.0 * ((beam - noise_beam) / noise_beam).max(1e-12).log10();
        let maxp = self.proc.max_angle_peaks_per_cell.clamp(1, MAX_ANGLE_PEAKS);
        let mut comps = [AngleComp::default(); MAX_ANGLE_PEAKS];
        b.d.copy_from(&b.x);
        comps[0] = self.fit_component(b, 0, None, &[]);
        if snr_db_of(comps[0].beam) < self.proc.min_snr_db {
            return res;
        }
        let mut count = 1;
        // Secondary peaks: beam/noise ≥ ln(1/P_FA) and ≥ 1 + 10^{min_snr/10}.
        let min_ratio = (1.0 / self.proc.cfar.p_fa)
            .ln()
            .max(1.0 + 10f64.powf(self.proc.min_snr_db / 10.0));
        let dyn_range = 10f64.powf(-self.proc.angle_peak_dynamic_range_db / 10.0);
        while count < maxp {
            // Residual after all components; its strongest peak is the candidate.
            self.residual(b, &comps[..count], usize::MAX);
            let cand = self.fit_component(b, count, None, &comps[..count]);
            let strongest = comps[..count].iter().map(|c| c.beam).fold(0.0, f64::max);
            let crowded = comps[..count]
                .iter()
                .any(|c| (c.sy - cand.sy).abs() < self.angle_res_sin);
            if crowded || cand.beam < dyn_range * strongest || cand.beam < min_ratio * noise_beam {
                break;
            }
            comps[count] = cand;
            count += 1;
            // RELAX sweeps, each component re-fitted near its position with the others removed.
            for _ in 0..RELAX_SWEEPS {
                for j in 0..count {
                    self.residual(b, &comps[..count], j);
                    comps[j] = self.fit_component(b, j, Some(comps[j].sy), &[]);
                }
            }
        }
        // Joint refinement of the complete model, then acceptance; a failing set loses its
        // weakest component and is refined again.
        while count > 1 {
            self.refine_jointly(b, &mut comps[..count]);
            let Some(drop) =
                self.failing_component(&comps[..count], dyn_range, min_ratio * noise_beam)
            else {
                break;
            };
            comps.copy_within(drop + 1..count, drop);
            count -= 1;
            for j in 0..count {
                self.steering(comps[j].sy, comps[j].sz, b, j);
            }
            if count == 1 {
                self.residual(b, &comps[..1], 0);
                comps[0] = self.fit_component(b, 0, Some(comps[0].sy), &[]);
            }
        }
        let comps = &mut comps[..count];
        comps.sort_by(|a, b| b.beam.total_cmp(&a.beam));
        // Power: per-channel amplitude minus its noise (E|â|² = |a|² + σ²_cell/N_k), straddle
        // corrected with the range-Doppler interpolation (peak / v0).
        let straddle = peak / (v0 as f64).max(1e-38);
        let (rb, db) = (n as f64 + dn, d_signed + dd);
        for (slot, c) in res.iter_mut().zip(comps.iter()) {
            let snr_db = snr_db_of(c.beam);
            if snr_db < self.proc.min_snr_db {
                continue;
            }
            // Per-angle peak grouping: the range main lobe of a centre in the next cell.
            if self.proc.peak_grouping && self.proc.peak_grouping_per_angle {
                let own = self.beam_in_cell(n, d, v, c.sy, c.sz);
                let hit = |m: usize| self.hit_map[m * nc + d];
                if (n > 0 && hit(n - 1) && self.beam_in_cell(n - 1, d, v, c.sy, c.sz) >= own)
                    || (n + 1 < ns
                        && hit(n + 1)
                        && self.beam_in_cell(n + 1, d, v, c.sy, c.sz) > own)
                {
                    continue;
                }
            }
            // Sines folded into the array's unambiguous interval (sparse arrays).
            let sz = principal(c.sz, self.sz_period);
            let sy = principal(c.sy, self.sy_period);
            let el = sz.clamp(-1.0, 1.0).asin();
            let az = (sy / el.cos().max(1e-9)).clamp(-1.0, 1.0).asin();
            let g = &self.gate_rad;
            if self.proc.field_of_view_gate
                && !(az >= g[0] && az <= g[1] && el >= g[2] && el <= g[3])
            {
                continue;
            }
            let sig = ((c.amp.norm_sqr() - self.noise_cell / nk as f64) * straddle).max(1e-30);
            let power_w = sig / self.coherent_gain;
            *slot = Some(ChainDetection {
                range_m: range,
                range_rate_m_s: v,
                azimuth_rad: az,
                elevation_rad: el,
                power_dbm: 10.0 * (power_w * 1e3).log10(),
                snr_db,
                object_id: self.object_of(rb, db, c.sy),
            });
        }
        res
    }

    /// `b.x` ← the channel vector of cell (`n`, `d`) with the TDM Doppler phase of each Tx slot
    /// for range rate `v` removed (`tdm_doppler_compensation`). A virtual element at (y, z) (λ/2
    /// units) sees x ∝ e^{−jπ(y s_y + z s_z)}, s_y = cos el sin az, s_z = sin el.
    fn load_cell(&self, n: usize, d: usize, v: f64, b: &mut AngleBufs) {
        let (nk, nc) = (self.nk, self.nc);
        for k in 0..nk {
            let mut x = self.dop[(n * nk + k) * nc + d];
            if self.tdm && self.proc.tdm_doppler_compensation {
                let t = k / self.nrx;
                let ph =
                    -4.0 * std::f64::consts::PI * v * t as f64 * self.t_chirp_s / self.lambda_m;
                x *= C32::new(ph.cos() as f32, ph.sin() as f32);
            }
            b.x.re[k] = x.re as f64;
            b.x.im[k] = x.im as f64;
        }
    }

    /// Windowed beam power `|Σ_k w_k x_k e^{jπ(y_k s_y + z_k s_z)}|²` of cell (`n`, `d`) towards
    /// the sines (`sy`, `sz`), the Tx slots compensated for range rate `v` as in
    /// [`Self::load_cell`] (the per-angle range grouping,
    /// `ProcessingConfig::peak_grouping_per_angle`).
    fn beam_in_cell(&self, n: usize, d: usize, v: f64, sy: f64, sz: f64) -> f64 {
        let (nk, nc) = (self.nk, self.nc);
        let tdm = self.tdm && self.proc.tdm_doppler_compensation;
        let mut beam = Complex64::default();
        for (k, (p, w)) in self.virt.iter().zip(&self.angle_win).enumerate() {
            let x = self.dop[(n * nk + k) * nc + d];
            let mut ph = std::f64::consts::PI * (p[0] as f64 * sy + p[1] as f64 * sz);
            if tdm {
                let t = k / self.nrx;
                ph -= 4.0 * std::f64::consts::PI * v * t as f64 * self.t_chirp_s / self.lambda_m;
            }
            beam += Complex64::new(x.re as f64, x.im as f64) * Complex64::from_polar(*w as f64, ph);
        }
        beam.norm_sqr()
    }

    /// TDM-MIMO Doppler ambiguity (`ProcessingConfig::velocity_disambiguation`): the range rate
    /// `v_folded` of the Doppler bin is `v + 2 v_max j` for an unknown integer j
    /// (`2 v_max = λ / (2 N_tx T_c)`); compensating the Tx slots with the wrong j leaves slot t a
    /// phase error 2π j t / N_tx (the N_tx residues of j are distinguishable, the rest is not).
    /// Each of the N_tx hypotheses with `v ∈ [−N_tx v_max, N_tx v_max)` is compensated, and the
    /// one with the strongest beam `|Σ_k w_k x_k e^{jπ(y_k s_y + z_k s_z)}|²` over the angle gate
    /// (azimuth FFT bins inside it, elevation samples across it) wins; ties keep the folded rate
    /// (j = 0). The winner's vector is left in `b.x`; returns its range rate.
    fn disambiguate_velocity(&self, n: usize, d: usize, v_folded: f64, b: &mut AngleBufs) -> f64 {
        let two_vmax = self.lambda_m / (2.0 * self.t_rep_s);
        let n_h = self.ntx as i64;
        let v_ext = 0.5 * n_h as f64 * two_vmax;
        let j0 = ((-v_ext - v_folded) / two_vmax).ceil() as i64;
        let (mut best_v, mut best_m) = (v_folded, f64::NEG_INFINITY);
        for j in std::iter::once(0).chain((j0..j0 + n_h).filter(|&j| j != 0)) {
            let v = v_folded + two_vmax * j as f64;
            self.load_cell(n, d, v, b);
            let m = self.gate_beam_peak(b);
            // A relative margin: hypotheses the array cannot tell apart tie up to rounding.
            if m > best_m * (1.0 + 1e-9) {
                (best_v, best_m) = (v, m);
            }
        }
        self.load_cell(n, d, best_v, b);
        best_v
    }

    /// The strongest beam power of `b.x` inside the angle gate: for each elevation sample of
    /// the gate, the windowed aperture steered to it and projected onto the horizontal axis,
    /// zero-padded azimuth FFT, maximum over the bins inside the gate.
    fn gate_beam_peak(&self, b: &mut AngleBufs) -> f64 {
        let nk = self.nk;
        let mut best = 0f64;
        for wts in self.hyp_weights.chunks_exact(nk) {
            b.line.fill(C32::default());
            for (k, (p, w)) in self.virt.iter().zip(wts).enumerate() {
                let v = b.x.get(k) * w;
                b.line[(p[0] - self.y_min) as usize] += C32::new(v.re as f32, v.im as f32);
            }
            self.fft_az
                .process_with_scratch(&mut b.line, &mut b.scratch);
            for &q in &self.hyp_bins {
                best = best.max(b.line[q].norm_sqr() as f64);
            }
        }
        best
    }

    /// Concentrated least-squares cost `‖x − E(s) â‖²` of the components (steering vectors in
    /// `b.steer`), with the amplitudes `â = (EᴴE)⁻¹ Eᴴx` solved jointly (written to `amps`); the
    /// residual into `b.r`, the Gram matrix and `Eᴴx` into `b.gram`.
    // Small dense linear algebra over component indices: index loops are the clearest form.
    #[allow(clippy::needless_range_loop)]
    fn joint_cost(
        &self,
        b: &mut AngleBufs,
        kc: usize,
        amps: &mut [Complex64; MAX_ANGLE_PEAKS],
    ) -> f64 {
        let nk = self.nk;
        // The Gram matrix EᴴE is Hermitian: its upper triangle, mirrored.
        let g = &mut b.gram;
        for i in 0..kc {
            let ci = b.steer.seg(i * nk, nk);
            for l in i..kc {
                let s = dot_conj(ci, b.steer.seg(l * nk, nk));
                g[i][l] = s;
                g[l][i] = s.conj();
            }
            g[i][kc] = dot_conj(ci, b.x.seg(0, nk));
        }
        let g = b.gram;
        self.solve_cost(b, g, kc, None, amps)
    }

    /// [`Self::joint_cost`] with the steering vector of component `j` replaced by `b.tmp`, from
    /// the Gram matrix of the unreplaced set in `b.gram` (only row and column `j` and `Eᴴx`'s
    /// entry `j` change; the same values as a full evaluation).
    fn joint_cost_replaced(
        &self,
        b: &mut AngleBufs,
        kc: usize,
        j: usize,
        amps: &mut [Complex64; MAX_ANGLE_PEAKS],
    ) -> f64 {
        let nk = self.nk;
        let mut g = b.gram;
        let cj = b.tmp.seg(0, nk);
        for i in 0..kc {
            let ci = if i == j { cj } else { b.steer.seg(i * nk, nk) };
            let (lo, hi) = (i.min(j), i.max(j));
            let s = if i <= j {
                dot_conj(ci, cj)
            } else {
                dot_conj(cj, ci)
            };
            g[lo][hi] = s;
            g[hi][lo] = s.conj();
        }
        g[j][kc] = dot_conj(cj, b.x.seg(0, nk));
        self.solve_cost(b, g, kc, Some(j), amps)
    }

    /// Solve the augmented system `g` (Gram matrix | Eᴴx) for the amplitudes, residual
    /// `x − E â` into `b.r` (component `replaced` taken from `b.tmp`), returns `‖x − E â‖²`.
    // Small dense linear algebra over component indices: index loops are the clearest form.
    #[allow(clippy::needless_range_loop)]
    fn solve_cost(
        &self,
        b: &mut AngleBufs,
        mut g: Gram,
        kc: usize,
        replaced: Option<usize>,
        amps: &mut [Complex64; MAX_ANGLE_PEAKS],
    ) -> f64 {
        let nk = self.nk;
        // Gaussian elimination with partial pivoting on the augmented K × (K+1) system.
        for c in 0..kc {
            let piv = (c..kc)
                .max_by(|&a, &bb| g[a][c].norm_sqr().total_cmp(&g[bb][c].norm_sqr()))
                .unwrap_or(c);
            g.swap(c, piv);
            let d = g[c][c];
            if d.norm_sqr() < 1e-30 {
                return f64::INFINITY;
            }
            for r in c + 1..kc {
                let f = g[r][c] / d;
                for cc in c..=kc {
                    let v = g[c][cc];
                    g[r][cc] -= f * v;
                }
            }
        }
        for c in (0..kc).rev() {
            let mut s = g[c][kc];
            for cc in c + 1..kc {
                s -= g[c][cc] * amps[cc];
            }
            amps[c] = s / g[c][c];
        }
        // ‖x − E â‖² = ‖x‖² − Re(rᴴ â) at the LS solution; evaluated directly for robustness.
        let AngleBufs {
            x, steer, tmp, r, ..
        } = b;
        r.copy_from(x);
        for (i, a) in amps.iter().enumerate().take(kc) {
            let col = if replaced == Some(i) {
                tmp.seg(0, nk)
            } else {
                steer.seg(i * nk, nk)
            };
            sub_scaled(r, *a, col);
        }
        dot_re(r.seg(0, nk), r.seg(0, nk))
    }

    /// Joint refinement of the azimuths of several components: Gauss-Newton on the projected
    /// residual `x − E(s)(EᴴE)⁻¹Eᴴx` (variable projection: amplitudes solved jointly at every
    /// evaluation; Golub & Pereyra, SIAM J. Numer. Anal. 10(2), 1973), forward-difference
    /// Jacobian, step halving until the cost falls; then joint amplitudes, elevations
    /// (matched sub-apertures on each component's data) and beam powers.
    // Small dense linear algebra over component indices: index loops are the clearest form.
    #[allow(clippy::needless_range_loop)]
    fn refine_jointly(&self, b: &mut AngleBufs, comps: &mut [AngleComp]) {
        let kc = comps.len();
        let mut amps = [Complex64::default(); MAX_ANGLE_PEAKS];
        let nk = self.nk;
        const DELTA: f64 = 1e-6;
        let max_step = 0.5 * self.angle_res_sin;
        for _ in 0..JOINT_ITERATIONS {
            let j0 = self.joint_cost(b, kc, &mut amps);
            b.r0.copy_from(&b.r);
            // Jacobian of the projected residual by forward differences, one column per azimuth.
            for j in 0..kc {
                {
                    let AngleBufs {
                        tmp, pow_y, pow_z, ..
                    } = &mut *b;
                    let (re, im) = tmp.seg_mut(0, nk);
                    let z = &mut pow_z[j];
                    self.steer_plan
                        .vector(comps[j].sy + DELTA, comps[j].sz, pow_y, z, re, im);
                }
                self.joint_cost_replaced(b, kc, j, &mut amps);
                let (jr, ji) = b.jac.seg_mut(j * nk, nk);
                for (jac, (r, r0)) in jr.iter_mut().zip(b.r.re.iter().zip(&b.r0.re)) {
                    *jac = (r - r0) * (1.0 / DELTA);
                }
                for (jac, (r, r0)) in ji.iter_mut().zip(b.r.im.iter().zip(&b.r0.im)) {
                    *jac = (r - r0) * (1.0 / DELTA);
                }
            }
            // Gauss-Newton normal equations over real Δs (Levenberg damping 1e-9 · trace).
            let mut a = [[0f64; MAX_ANGLE_PEAKS + 1]; MAX_ANGLE_PEAKS];
            for i in 0..kc {
                let ji = b.jac.seg(i * nk, nk);
                for l in i..kc {
                    let v = dot_re(ji, b.jac.seg(l * nk, nk));
                    a[i][l] = v;
                    a[l][i] = v;
                }
                a[i][kc] = -dot_re(ji, b.r0.seg(0, nk));
            }
            let trace: f64 = (0..kc).map(|i| a[i][i]).sum();
            for (i, row) in a.iter_mut().enumerate().take(kc) {
                row[i] += 1e-9 * trace + 1e-300;
            }
            let mut step = [0f64; MAX_ANGLE_PEAKS];
            if !solve_real(&mut a, kc, &mut step) {
                break;
            }
            let mut scale = 1.0;
            let mut accepted = false;
            for _ in 0..6 {
                for j in 0..kc {
                    let sy = (comps[j].sy + (scale * step[j]).clamp(-max_step, max_step))
                        .clamp(-1.0, 1.0);
                    self.steering(sy, comps[j].sz, b, j);
                }
                // Components may not merge (ill-conditioned pairs of nearly equal steering
                // vectors with large opposite amplitudes): keep them half a cell apart. (A full
                // cell, the acceptance's separation, stops anti-phase neighbours 1.2 cells apart
                // from converging: their one-at-a-time estimates start closer than a cell;
                // radar_baseband's three-targets test. On an extended target the acceptance then
                // drops the weaker of a pair that came too close, not the weakest of all.)
                let mut apart = true;
                for i in 0..kc {
                    for l in i + 1..kc {
                        let si = comps[i].sy + (scale * step[i]).clamp(-max_step, max_step);
                        let sl = comps[l].sy + (scale * step[l]).clamp(-max_step, max_step);
                        apart &= (si - sl).abs() >= 0.5 * self.angle_res_sin;
                    }
                }
                if apart && self.joint_cost(b, kc, &mut amps) < j0 {
                    accepted = true;
                    break;
                }
                scale *= 0.5;
            }
            let mut moved = 0f64;
            for j in 0..kc {
                if accepted {
                    let d = (scale * step[j]).clamp(-max_step, max_step);
                    comps[j].sy = (comps[j].sy + d).clamp(-1.0, 1.0);
                    moved = moved.max(d.abs());
                }
                self.steering(comps[j].sy, comps[j].sz, b, j);
            }
            if !accepted || moved < 1e-7 {
                break;
            }
        }
        self.joint_cost(b, kc, &mut amps);
        for (c, a) in comps.iter_mut().zip(&amps) {
            c.amp = *a;
        }
        // Elevation and beam of each component from its own data (the others subtracted).
        for j in 0..kc {
            self.residual(b, comps, j);
            let sz = self.elevation_sine(b, comps[j].sy);
            comps[j].sz = sz;
            self.steering(comps[j].sy, sz, b, j);
            let nk = self.nk;
            let (_, beam) = project(&b.d, b.steer.seg(j * nk, nk), &self.angle_win);
            comps[j].beam = beam.norm_sqr();
        }
        self.joint_cost(b, kc, &mut amps);
        for (c, a) in comps.iter_mut().zip(&amps) {
            c.amp = *a;
        }
    }

    /// `b.d = b.x − Σ_{j ≠ skip} a_j e_j` (steering vectors in `b.steer`).
    fn residual(&self, b: &mut AngleBufs, comps: &[AngleComp], skip: usize) {
        let nk = self.nk;
        b.d.copy_from(&b.x);
        for (j, c) in comps.iter().enumerate() {
            if j != skip {
                sub_scaled(&mut b.d, c.amp, b.steer.seg(j * nk, nk));
            }
        }
    }

    /// Steering vector `e^{−jπ(y s_y + z s_z)}` of component slot `j` into `b.steer`.
    fn steering(&self, sy: f64, sz: f64, b: &mut AngleBufs, j: usize) {
        let nk = self.nk;
        let AngleBufs {
            steer,
            pow_y,
            pow_z,
            ..
        } = b;
        let (re, im) = steer.seg_mut(j * nk, nk);
        self.steer_plan.vector(sy, sz, pow_y, &mut pow_z[j], re, im);
    }

    /// One component from `b.d`: azimuth from the strongest peak of the zero-padded spectrum of
    /// the windowed aperture projected onto the horizontal axis (the elevation-0 beam; rows
    /// sharing their phase centre keep it unbiased), parabolic interpolation; elevation from the
    /// matched sub-apertures; least-squares amplitude. Steering vector into slot `j`.
    ///
    /// `avoid`: the components found so far; the candidate is then the strongest local maximum
    /// of the spectrum at least one resolution cell from each of them (the residual of an
    /// extended target, a continuum the components model only in part, peaks next to them).
    fn fit_component(
        &self,
        b: &mut AngleBufs,
        j: usize,
        near: Option<f64>,
        avoid: &[AngleComp],
    ) -> AngleComp {
        let az_len = self.az_len;
        b.line.fill(C32::default());
        for (k, (p, w)) in self.virt.iter().zip(&self.angle_win).enumerate() {
            let iy = (p[0] - self.y_min) as usize;
            let w = *w as f64;
            b.line[iy] += C32::new((b.d.re[k] * w) as f32, (b.d.im[k] * w) as f32);
        }
        self.fft_az
            .process_with_scratch(&mut b.line, &mut b.scratch);
        let (mut best, mut qy) = (-1f32, 0usize);
        // Bin of a sine: q = −s A / 2 (mod A); a re-fit stays within half a resolution cell.
        let window = near.map(|s0| {
            let q0 = (-s0 * az_len as f64 / 2.0).rem_euclid(az_len as f64);
            (q0, 0.25 * self.angle_res_sin * az_len as f64)
        });
        let sine_of = |i: usize| {
            let signed = if i >= az_len / 2 {
                i as f64 - az_len as f64
            } else {
                i as f64
            };
            -2.0 * signed / az_len as f64
        };
        for (i, v) in b.line.iter().enumerate() {
            if let Some((q0, half)) = window {
                let dq = (i as f64 - q0).rem_euclid(az_len as f64);
                if dq.min(az_len as f64 - dq) > half {
                    continue;
                }
            }
            let m = v.norm_sqr();
            if !avoid.is_empty() {
                let s = sine_of(i);
                if avoid.iter().any(|c| (c.sy - s).abs() < self.angle_res_sin)
                    || m < b.line[(i + az_len - 1) % az_len].norm_sqr()
                    || m < b.line[(i + 1) % az_len].norm_sqr()
                {
                    continue;
                }
            }
            if m > best {
                best = m;
                qy = i;
            }
        }
        let mag = |i: usize| b.line[i % az_len].norm_sqr() as f64;
        let (oy, _) = processing::parabolic_peak(mag(qy + az_len - 1), best as f64, mag(qy + 1));
        let signed = if qy >= az_len / 2 {
            qy as f64 - az_len as f64
        } else {
            qy as f64
        };
        let sy = (-2.0 * (signed + oy) / az_len as f64).clamp(-1.0, 1.0);
        let sz = self.elevation_sine(b, sy);
        self.steering(sy, sz, b, j);
        let nk = self.nk;
        let (a, beam) = project(&b.d, b.steer.seg(j * nk, nk), &self.angle_win);
        AngleComp {
            sy,
            sz,
            amp: a / nk as f64,
            beam: beam.norm_sqr(),
        }
    }

    /// Elevation sine of the data in `b.d` at azimuth sine `sy`: each occupied row is steered to
    /// `sy` over the columns common to all rows (identical horizontal sub-apertures, so targets
    /// sharing one elevation leave no inter-row phase, whatever their azimuths), then the row
    /// phases give s_z: for two rows `s_z = −arg(S₁ S₀*) / (π Δz)`; for more, the maximum of
    /// `|Σ_r S_r e^{jπ z_r s}|` on a fine grid, interpolated.
    fn elevation_sine(&self, b: &mut AngleBufs, sy: f64) -> f64 {
        if !self.has_el || self.el_rows.len() < 2 {
            return 0.0;
        }
        b.rows.fill(Complex64::default());
        // e^{jπ y sy} = conj(e^{−jπ y sy}): the steering vector's per-column phasors.
        let plan = &self.steer_plan;
        axis_powers(sy, plan.lo[0], &mut b.pow_y.re, &mut b.pow_y.im);
        for k in 0..self.nk {
            if self.el_match[k] {
                let iy = plan.idx[k][0] as usize;
                let e = Complex64::new(b.pow_y.re[iy], -b.pow_y.im[iy]);
                b.rows[self.el_row_of[k]] += b.d.get(k) * e;
            }
        }
        let rz = |ri: usize| self.el_rows[ri] as f64;
        if self.el_rows.len() == 2 {
            let dz = rz(1) - rz(0);
            return (-(b.rows[1] * b.rows[0].conj()).arg() / (std::f64::consts::PI * dz))
                .clamp(-1.0, 1.0);
        }
        let m = 8 * self.el_len;
        // |Σ_r S_r e^{jπ z_r s_i}|² for every grid point i, the rows in order (vectorised over i).
        let (vr, vi) = (&mut b.el_val.re[..m], &mut b.el_val.im[..m]);
        vr.fill(0.0);
        vi.fill(0.0);
        for (r, sr) in b.rows.iter().enumerate() {
            let (er, ei) = (
                &self.el_steer_re[r * m..(r + 1) * m],
                &self.el_steer_im[r * m..(r + 1) * m],
            );
            for (((vr, vi), er), ei) in vr.iter_mut().zip(vi.iter_mut()).zip(er).zip(ei) {
                *vr += sr.re * er - sr.im * ei;
                *vi += sr.re * ei + sr.im * er;
            }
        }
        for (vr, vi) in vr.iter_mut().zip(vi.iter()) {
            *vr = *vr * *vr + *vi * *vi;
        }
        let val = |i: usize| b.el_val.re[i % m];
        let (mut best, mut bi) = (-1.0, 0);
        for i in 0..m {
            let v = val(i);
            if v > best {
                best = v;
                bi = i;
            }
        }
        let (o, _) = processing::parabolic_peak(val(bi + m - 1), best, val(bi + 1));
        (-1.0 + 2.0 * (bi as f64 + o) / m as f64).clamp(-1.0, 1.0)
    }

    /// Acceptance of a set of components: every one but the strongest within the dynamic range
    /// of the strongest and above `min_beam`; no two closer than the angular resolution. Returns
    /// the component to drop when the set fails: the weakest of those below the dynamic range or
    /// `min_beam`, else the weaker of the closest pair (a pair of unresolved components must not
    /// cost the set its resolved ones: dropping the weakest of the whole set would).
    fn failing_component(
        &self,
        comps: &[AngleComp],
        dyn_range: f64,
        min_beam: f64,
    ) -> Option<usize> {
        let strongest = comps.iter().map(|c| c.beam).fold(0.0, f64::max);
        let weak = (0..comps.len())
            .filter(|&i| {
                let c = &comps[i];
                c.beam < strongest && (c.beam < dyn_range * strongest || c.beam < min_beam)
            })
            .min_by(|&i, &l| comps[i].beam.total_cmp(&comps[l].beam));
        if weak.is_some() {
            return weak;
        }
        let mut closest: Option<(f64, usize)> = None;
        for (i, c) in comps.iter().enumerate() {
            for (l, o) in comps.iter().enumerate().skip(i + 1) {
                let sep = (c.sy - o.sy).abs();
                if sep < self.angle_res_sin && closest.is_none_or(|(s, _)| sep < s) {
                    closest = Some((sep, if c.beam < o.beam { i } else { l }));
                }
            }
        }
        closest.map(|(_, i)| i)
    }

    /// Object of a detection at range bin `rb`, signed Doppler bin `db`, azimuth sine `sy`: among
    /// the paths within one bin in range and Doppler, the nearest in azimuth (paths within half
    /// a resolution cell of each other count as equally near), the strongest among those.
    fn object_of(&self, rb: f64, db: f64, sy: f64) -> u64 {
        let ncf = self.nc as f64;
        let first = self.path_bins.partition_point(|x| x.0 < rb - 1.0);
        let half = 0.5 * self.angle_res_sin;
        // (azimuth distance, −power, id)
        let mut obj: Option<(f64, f64, u64)> = None;
        for &(pr, pd, i) in self.path_bins[first..]
            .iter()
            .take_while(|x| x.0 <= rb + 1.0)
        {
            if (pr - rb).abs() > 1.0 {
                continue;
            }
            let diff = (pd - db).rem_euclid(ncf);
            if diff.min(ncf - diff) > 1.0 {
                continue;
            }
            let path = &self.paths[i as usize];
            let dist = (path.sin_az - sy).abs();
            let dist = if dist < half { 0.0 } else { dist };
            let key = (dist, -path.amplitude_sq_w, path.object_id);
            if obj.is_none_or(|o| (key.0, key.1) < (o.0, o.1)) {
                obj = Some(key);
            }
        }
        obj.map_or(osiris_proto::INVALID_ID, |o| o.2)
    }
}

/// Per-worker buffers of the angle FFT.
struct AngleBufs {
    /// Zero-padded azimuth line (all rows projected onto the horizontal axis).
    line: Vec<C32>,
    scratch: Vec<C32>,
    /// The cell's virtual-channel vector after TDM compensation.
    x: Split,
    /// Data of one component (x minus the other components).
    d: Split,
    /// Steering vectors of the components, `[component][k]`.
    steer: Split,
    /// Matched-aperture row sums for the elevation estimate.
    rows: Vec<Complex64>,
    /// A trial steering vector.
    tmp: Split,
    /// Projected residuals (current, reference) and their Jacobian `[component][k]`.
    r: Split,
    r0: Split,
    jac: Split,
    /// Powers of the per-axis phasors of [`SteerPlan::vector`] (offset by the smallest
    /// coordinate): horizontal, and vertical per component slot (kept while its elevation sine
    /// stays: the azimuth refinement moves only s_y).
    pow_y: Split,
    pow_z: Vec<AxisPowers>,
    /// The elevation search's beam over its grid (before `|·|²`).
    el_val: Split,
    /// Gram matrix `EᴴE | Eᴴx` of the last [`RadarChain::joint_cost`].
    gram: Gram,
}

/// An augmented `K × (K+1)` complex system of the joint amplitude fit.
type Gram = [[Complex64; MAX_ANGLE_PEAKS + 1]; MAX_ANGLE_PEAKS];

/// A complex vector as separate real and imaginary parts: the estimator's dot products and
/// updates over the virtual channels vectorise over them.
#[derive(Debug, Clone, Default)]
struct Split {
    re: Vec<f64>,
    im: Vec<f64>,
}

impl Split {
    fn zeros(n: usize) -> Split {
        Split {
            re: vec![0.0; n],
            im: vec![0.0; n],
        }
    }

    fn get(&self, k: usize) -> Complex64 {
        Complex64::new(self.re[k], self.im[k])
    }

    fn copy_from(&mut self, o: &Split) {
        self.re.copy_from_slice(&o.re);
        self.im.copy_from_slice(&o.im);
    }

    /// Elements `at .. at + n`.
    fn seg(&self, at: usize, n: usize) -> (&[f64], &[f64]) {
        (&self.re[at..at + n], &self.im[at..at + n])
    }

    fn seg_mut(&mut self, at: usize, n: usize) -> (&mut [f64], &mut [f64]) {
        (&mut self.re[at..at + n], &mut self.im[at..at + n])
    }
}

/// `a · b + c`, fused (one rounding) in the AVX2 + FMA kernels, plain elsewhere (the portable
/// build has no FMA instruction; `mul_add` would call the C library).
#[inline(always)]
fn madd<const FMA: bool>(a: f64, b: f64, c: f64) -> f64 {
    if FMA { a.mul_add(b, c) } else { a * b + c }
}

/// A kernel `body::<FMA>` compiled for AVX2 + FMA (`FMA = true`) where [`crate::cpu::avx2_fma`]
/// allows (run-time dispatch), else portable (`FMA = false`; the results differ by rounding).
macro_rules! dispatch_avx2 {
    ($(#[$m:meta])* fn $name:ident($($a:ident: $t:ty),*) $(-> $r:ty)? $body:block) => {
        $(#[$m])*
        #[inline]
        fn $name($($a: $t),*) $(-> $r)? {
            #[inline(always)]
            fn body<const FMA: bool>($($a: $t),*) $(-> $r)? $body
            #[cfg(target_arch = "x86_64")]
            {
                #[target_feature(enable = "avx2,fma")]
                fn avx2($($a: $t),*) $(-> $r)? {
                    body::<true>($($a),*)
                }
                if crate::cpu::avx2_fma() {
                    // SAFETY: the CPU supports AVX2 and FMA (run-time check).
                    return unsafe { avx2($($a),*) };
                }
            }
            body::<false>($($a),*)
        }
    };
}

/// Partial sums per dot product term (portable kernels: 4 × 2 f64 registers; AVX2: 2 × 4).
const LANES: usize = 8;

/// `Σ_k conj(a_k) b_k`: the products of real and imaginary parts in separate partial sums, so
/// no sum takes more than one add per LANES elements (no long chain of dependent adds). AVX2 +
/// FMA kernel where [`crate::cpu::avx2_fma`] allows (fused: the results differ by rounding).
#[inline]
fn dot_conj(a: (&[f64], &[f64]), b: (&[f64], &[f64])) -> Complex64 {
    let s = dot_sums::<true>(a, b);
    Complex64::new(reduce(s[0]) + reduce(s[1]), reduce(s[2]) - reduce(s[3]))
}

/// `Re Σ_k conj(a_k) b_k` (as [`dot_conj`]).
#[inline]
fn dot_re(a: (&[f64], &[f64]), b: (&[f64], &[f64])) -> f64 {
    let s = dot_sums::<false>(a, b);
    reduce(s[0]) + reduce(s[1])
}

/// The partial sums of [`dot_conj`] (`IM`: all four, `Σ ar br, Σ ai bi, Σ ar bi, Σ ai br`) or of
/// [`dot_re`] (the first two; the others stay zero), LANES each: [`dot_avx2`] where
/// [`crate::cpu::avx2_fma`] allows, else [`dot_portable`].
#[inline(always)]
fn dot_sums<const IM: bool>(a: (&[f64], &[f64]), b: (&[f64], &[f64])) -> [[f64; LANES]; 4] {
    #[cfg(target_arch = "x86_64")]
    if crate::cpu::avx2_fma() {
        // SAFETY: the CPU supports AVX2 and FMA (run-time check).
        return unsafe { dot_avx2::<IM>(a, b) };
    }
    dot_portable::<IM>(a, b)
}

/// The partial sums of [`dot_sums`] without FMA (plain multiply and add).
#[inline(always)]
fn dot_portable<const IM: bool>(
    (ar, ai): (&[f64], &[f64]),
    (br, bi): (&[f64], &[f64]),
) -> [[f64; LANES]; 4] {
    let (mut s1, mut s2) = ([0f64; LANES], [0f64; LANES]);
    let (mut s3, mut s4) = ([0f64; LANES], [0f64; LANES]);
    let q = ar.chunks_exact(LANES);
    let tail = q.remainder().len();
    for (((ar, ai), br), bi) in q
        .zip(ai.chunks_exact(LANES))
        .zip(br.chunks_exact(LANES))
        .zip(bi.chunks_exact(LANES))
    {
        for l in 0..LANES {
            s1[l] += ar[l] * br[l];
            s2[l] += ai[l] * bi[l];
            if IM {
                s3[l] += ar[l] * bi[l];
                s4[l] += ai[l] * br[l];
            }
        }
    }
    let n = ar.len();
    for k in n - tail..n {
        s1[0] += ar[k] * br[k];
        s2[0] += ai[k] * bi[k];
        if IM {
            s3[0] += ar[k] * bi[k];
            s4[0] += ai[k] * br[k];
        }
    }
    [s1, s2, s3, s4]
}

/// The partial sums of [`dot_sums`] with AVX2 + FMA.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
// The two halves of each partial sum, indexed alike: index loops are the clearest form.
#[allow(clippy::needless_range_loop)]
fn dot_avx2<const IM: bool>(
    (ar, ai): (&[f64], &[f64]),
    (br, bi): (&[f64], &[f64]),
) -> [[f64; LANES]; 4] {
    use std::arch::x86_64::*;
    let n = ar.len();
    let (ai, br, bi) = (&ai[..n], &br[..n], &bi[..n]);
    let mut s = [[_mm256_setzero_pd(); 2]; 4];
    let body = n - n % LANES;
    for k in (0..body).step_by(LANES) {
        for h in 0..2 {
            let at = k + 4 * h;
            // SAFETY: at + 4 ≤ body ≤ n for all four slices (re-sliced to n above).
            let (xr, xi, yr, yi) = unsafe {
                (
                    _mm256_loadu_pd(ar.as_ptr().add(at)),
                    _mm256_loadu_pd(ai.as_ptr().add(at)),
                    _mm256_loadu_pd(br.as_ptr().add(at)),
                    _mm256_loadu_pd(bi.as_ptr().add(at)),
                )
            };
            s[0][h] = _mm256_fmadd_pd(xr, yr, s[0][h]);
            s[1][h] = _mm256_fmadd_pd(xi, yi, s[1][h]);
            if IM {
                s[2][h] = _mm256_fmadd_pd(xr, yi, s[2][h]);
                s[3][h] = _mm256_fmadd_pd(xi, yr, s[3][h]);
            }
        }
    }
    let mut out = [[0f64; LANES]; 4];
    for (o, s) in out.iter_mut().zip(&s) {
        // SAFETY: 2 × 4 f64 into an array of 8.
        unsafe {
            _mm256_storeu_pd(o.as_mut_ptr(), s[0]);
            _mm256_storeu_pd(o.as_mut_ptr().add(4), s[1]);
        }
    }
    for k in body..n {
        out[0][0] = ar[k].mul_add(br[k], out[0][0]);
        out[1][0] = ai[k].mul_add(bi[k], out[1][0]);
        if IM {
            out[2][0] = ar[k].mul_add(bi[k], out[2][0]);
            out[3][0] = ai[k].mul_add(br[k], out[3][0]);
        }
    }
    out
}

/// The sum of the partial sums, pairwise.
#[inline(always)]
fn reduce(s: [f64; LANES]) -> f64 {
    ((s[0] + s[4]) + (s[1] + s[5])) + ((s[2] + s[6]) + (s[3] + s[7]))
}

dispatch_avx2! {
    /// `y −= a · e`.
    fn sub_scaled(y: &mut Split, a: Complex64, e: (&[f64], &[f64])) {
        let (er, ei) = e;
        for (((yr, yi), er), ei) in y.re.iter_mut().zip(y.im.iter_mut()).zip(er).zip(ei) {
            *yr = madd::<FMA>(a.im, *ei, madd::<FMA>(-a.re, *er, *yr));
            *yi = madd::<FMA>(-a.im, *er, madd::<FMA>(-a.re, *ei, *yi));
        }
    }
}

/// The least-squares projection of `d` onto the steering vector `e`: `(Σ_k d_k e_k*,
/// Σ_k w_k d_k e_k*)` (the plain and the windowed sum).
fn project(d: &Split, (er, ei): (&[f64], &[f64]), w: &[f32]) -> (Complex64, Complex64) {
    let n = er.len();
    let (dr, di, ei, w) = (&d.re[..n], &d.im[..n], &ei[..n], &w[..n]);
    let (mut a, mut beam) = ([0f64; 2], [0f64; 2]);
    for k in 0..n {
        let (tr, ti) = (dr[k] * er[k] + di[k] * ei[k], di[k] * er[k] - dr[k] * ei[k]);
        a[0] += tr;
        a[1] += ti;
        beam[0] += tr * w[k] as f64;
        beam[1] += ti * w[k] as f64;
    }
    (Complex64::new(a[0], a[1]), Complex64::new(beam[0], beam[1]))
}

/// `e^{−jπ s c}` for the coordinates `c = lo, lo + 1, …` (as many as `re` holds): blocks of
/// B ≈ √len powers of `e^{−jπ s}` by recurrence, times the block starts `e^{−jπ s (lo + B i)}`
/// by recurrence (≲ 2√len products from two exact `sincos`: relative rounding ≲ 1e-14 over an
/// aperture of hundreds of elements).
fn axis_powers(s: f64, lo: i32, re: &mut [f64], im: &mut [f64]) {
    let len = re.len();
    if len == 0 {
        return;
    }
    let bl = ((len as f64).sqrt().ceil() as usize).max(1);
    let step = Complex64::from_polar(1.0, -std::f64::consts::PI * s);
    // Powers 0 .. bl of the step into the first block (the start multiplies them below).
    let mut z = Complex64::new(1.0, 0.0);
    for k in 0..bl.min(len) {
        re[k] = z.re;
        im[k] = z.im;
        z *= step;
    }
    // z = e^{−jπ s B}: the stride between blocks.
    let start0 =
        (lo != 0).then(|| Complex64::from_polar(1.0, -std::f64::consts::PI * s * lo as f64));
    let mut start = start0.unwrap_or(Complex64::new(1.0, 0.0));
    let b0 = bl.min(len);
    let (r0, rest_re) = re.split_at_mut(b0);
    let (i0, rest_im) = im.split_at_mut(b0);
    for (br, bi) in rest_re.chunks_mut(bl).zip(rest_im.chunks_mut(bl)) {
        start *= z;
        // (a + jb)(c + jd), as `Complex64`'s product.
        for (((br, bi), ar), ai) in br.iter_mut().zip(bi.iter_mut()).zip(&*r0).zip(&*i0) {
            *br = ar * start.re - ai * start.im;
            *bi = ar * start.im + ai * start.re;
        }
    }
    // The first block last (the others read its plain powers); at lo = 0 it is the plain powers.
    if let Some(start0) = start0 {
        for k in 0..bl.min(len) {
            let p = Complex64::new(re[k], im[k]) * start0;
            re[k] = p.re;
            im[k] = p.im;
        }
    }
}

/// The phasors of [`axis_powers`] along one axis, with the sine they belong to (bits; NaN:
/// none yet).
#[derive(Debug, Clone)]
struct AxisPowers {
    s_bits: u64,
    p: Split,
}

impl AxisPowers {
    fn new(len: usize) -> AxisPowers {
        AxisPowers {
            s_bits: f64::NAN.to_bits(),
            p: Split::zeros(len),
        }
    }

    /// The phasors for sine `s` (recomputed only when `s` changed).
    fn at(&mut self, s: f64, lo: i32) -> &Split {
        if self.s_bits != s.to_bits() {
            axis_powers(s, lo, &mut self.p.re, &mut self.p.im);
            self.s_bits = s.to_bits();
        }
        &self.p
    }
}

/// The virtual array as integer coordinates for its steering vectors, planned once: per element
/// its column and row offsets from the smallest coordinates `lo`, the spans `len`, and the runs
/// of consecutive elements with consecutive columns in one row (a filled row is one run).
#[derive(Debug, Clone, Default)]
pub(in crate::radar) struct SteerPlan {
    idx: Vec<[u32; 2]>,
    /// `[first element, first column offset, row offset, length]`.
    runs: Vec<[u32; 4]>,
    lo: [i32; 2],
    len: [usize; 2],
}

impl SteerPlan {
    /// The plan of the virtual elements `virt` (λ/2 units).
    pub(in crate::radar) fn new(virt: &[[i32; 2]]) -> SteerPlan {
        let span = |axis: usize| {
            virt.iter().fold((i32::MAX, i32::MIN), |(lo, hi), p| {
                (lo.min(p[axis]), hi.max(p[axis]))
            })
        };
        let (ys, zs) = (span(0), span(1));
        let len = |(lo, hi): (i32, i32)| if lo > hi { 0 } else { (hi - lo + 1) as usize };
        let idx: Vec<[u32; 2]> = virt
            .iter()
            .map(|p| [(p[0] - ys.0) as u32, (p[1] - zs.0) as u32])
            .collect();
        let mut runs: Vec<[u32; 4]> = Vec::new();
        for (k, ix) in idx.iter().enumerate() {
            match runs.last_mut() {
                Some(r) if r[2] == ix[1] && r[1] + r[3] == ix[0] => r[3] += 1,
                _ => runs.push([k as u32, ix[0], ix[1], 1]),
            }
        }
        SteerPlan {
            idx,
            runs,
            lo: [ys.0, zs.0],
            len: [len(ys), len(zs)],
        }
    }

    /// The steering vector e^{−jπ(y_k s_y + z_k s_z)} of the virtual elements (y_k, z_k) into
    /// (`re`, `im`): the per-axis phasors e^{−jπ s c} for every coordinate ([`axis_powers`], into
    /// `pow_y`; `pow_z` keeps its phasors while s_z stays), multiplied per run of elements, so a
    /// vector costs a few `sincos` instead of one per element.
    fn vector(
        &self,
        sy: f64,
        sz: f64,
        pow_y: &mut Split,
        pow_z: &mut AxisPowers,
        re: &mut [f64],
        im: &mut [f64],
    ) {
        axis_powers(sy, self.lo[0], &mut pow_y.re, &mut pow_y.im);
        let pz = pow_z.at(sz, self.lo[1]);
        for &[k0, y0, z, n] in &self.runs {
            let (k0, y0, n) = (k0 as usize, y0 as usize, n as usize);
            let b = pz.get(z as usize);
            let (yr, yi) = (&pow_y.re[y0..y0 + n], &pow_y.im[y0..y0 + n]);
            let (or, oi) = (&mut re[k0..k0 + n], &mut im[k0..k0 + n]);
            if b == Complex64::new(1.0, 0.0) {
                // A row at z = 0 (e^{0} = 1 exactly): the product is the column phasor.
                or.copy_from_slice(yr);
                oi.copy_from_slice(yi);
                continue;
            }
            for (((or, oi), ar), ai) in or.iter_mut().zip(oi.iter_mut()).zip(yr).zip(yi) {
                *or = ar * b.re - ai * b.im;
                *oi = ar * b.im + ai * b.re;
            }
        }
    }
}

/// Solve the `n × n` real system augmented in column `n` (partial pivoting); false if singular.
// Small dense linear algebra over component indices: index loops are the clearest form.
#[allow(clippy::needless_range_loop)]
fn solve_real(
    a: &mut [[f64; MAX_ANGLE_PEAKS + 1]; MAX_ANGLE_PEAKS],
    n: usize,
    x: &mut [f64; MAX_ANGLE_PEAKS],
) -> bool {
    for c in 0..n {
        let piv = (c..n)
            .max_by(|&p, &q| a[p][c].abs().total_cmp(&a[q][c].abs()))
            .unwrap_or(c);
        a.swap(c, piv);
        if a[c][c].abs().partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater) {
            return false;
        }
        for r in c + 1..n {
            let f = a[r][c] / a[c][c];
            for cc in c..=n {
                a[r][cc] -= f * a[c][cc];
            }
        }
    }
    for c in (0..n).rev() {
        let mut s = a[c][n];
        for cc in c + 1..n {
            s -= a[c][cc] * x[cc];
        }
        x[c] = s / a[c][c];
    }
    x[..n].iter().all(|v| v.is_finite())
}

/// One angle component of a range-Doppler cell.
#[derive(Debug, Clone, Copy, Default)]
struct AngleComp {
    /// Direction sines `cos el sin az`, `sin el`.
    sy: f64,
    sz: f64,
    /// Least-squares complex amplitude per channel.
    amp: Complex64,
    /// Windowed beamformer output power `|Σ w_k d_k a_k*|²`.
    beam: f64,
}
