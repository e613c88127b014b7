//! 2-D CFAR over the range-Doppler power map: a second `impl` block of [`RadarChain`] (the
//! waveform side is in `baseband.rs`). The cell under test is compared with `α ẑ`, `ẑ` the noise
//! level estimated from the reference window around it (guard cells excluded, Doppler circular,
//! range truncated at the edges): CA from box sums over prefix sums, GO / SO from the leading and
//! lagging half windows, OS from the k-th smallest reference cell; `α` per range bin from
//! [`super::cfar_alpha`] (Richards §6.5; physics.md §1.7). With peak grouping only local maxima
//! of the 3 × 3 neighbourhood are tested. The hits (range bin, Doppler bin) go to `angle.rs`.

use crate::radar::baseband::RadarChain;
use crate::radar::processing::{self, CfarKind};

impl RadarChain {
    /// 2-D CFAR over the power map (Doppler circular, range truncated at the edges) → `hits`.
    pub(in crate::radar) fn cfar(&mut self) {
        let (ns, nc) = (self.ns, self.nc);
        let cf = self.proc.cfar.clone();
        let (gr, wr) = (cf.guard_range, cf.guard_range + cf.train_range);
        let (gd, wd) = (cf.guard_doppler, cf.guard_doppler + cf.train_doppler);
        let p = &self.power;
        // Circular row prefix sums: row_prefix[n][j] = Σ_{i<j} P[n][(i) mod nc], j ∈ 0..=3nc.
        let w = 3 * nc + 1;
        for n in 0..ns {
            let pre = &mut self.row_prefix[n * w..(n + 1) * w];
            pre[0] = 0.0;
            for j in 0..3 * nc {
                pre[j + 1] = pre[j] + p[n * nc + j % nc] as f64;
            }
        }
        let rp = &self.row_prefix;
        // Sum of row n over Doppler offsets a..=b around d (−nc < a ≤ b < nc).
        let row_sum = |n: usize, d: usize, a: isize, b: isize| -> f64 {
            let lo = (d as isize + a + nc as isize) as usize;
            let hi = (d as isize + b + nc as isize) as usize;
            rp[n * w + hi + 1] - rp[n * w + lo]
        };
        // Column prefix over range of the outer / guard Doppler box sums.
        for d in 0..nc {
            self.col_out[d] = 0.0;
            self.col_guard[d] = 0.0;
        }
        for n in 0..ns {
            for d in 0..nc {
                let o = row_sum(n, d, -(wd as isize), wd as isize);
                let g = row_sum(n, d, -(gd as isize), gd as isize);
                self.col_out[(n + 1) * nc + d] = self.col_out[n * nc + d] + o;
                self.col_guard[(n + 1) * nc + d] = self.col_guard[n * nc + d] + g;
            }
        }
        let (co, cg) = (&self.col_out, &self.col_guard);
        let box_sum = |col: &Vec<f64>, n: usize, d: usize, r: usize| {
            let lo = n.saturating_sub(r);
            let hi = (n + r).min(ns - 1);
            col[(hi + 1) * nc + d] - col[lo * nc + d]
        };
        // Per-angle grouping: local maxima along Doppler here, in range per direction after the
        // angle fit (`ProcessingConfig::peak_grouping_per_angle`).
        let per_angle = self.proc.peak_grouping_per_angle;
        let local_max = |n: usize, d: usize| {
            let v = p[n * nc + d];
            let rows = if per_angle { 0isize } else { 1 };
            for dn in -rows..=rows {
                let nn = n as isize + dn;
                if nn < 0 || nn >= ns as isize {
                    continue;
                }
                for dd in -1isize..=1 {
                    if dn == 0 && dd == 0 {
                        continue;
                    }
                    let q =
                        p[nn as usize * nc + (d as isize + dd).rem_euclid(nc as isize) as usize];
                    // Ties: the first cell in scan order wins.
                    if q > v || (q == v && (dn, dd) < (0, 0)) {
                        return false;
                    }
                }
            }
            true
        };
        self.hits.clear();
        let grouping = self.proc.peak_grouping;
        for n in 0..ns {
            for d in 0..nc {
                let x = p[n * nc + d] as f64;
                if grouping && !local_max(n, d) {
                    continue;
                }
                let threshold = match cf.kind {
                    CfarKind::Ca => {
                        let sum = box_sum(co, n, d, wr) - box_sum(cg, n, d, gr);
                        self.cfar_alpha[n] * sum / self.cfar_count[n] as f64
                    }
                    CfarKind::Go | CfarKind::So => {
                        // Leading half: rows before n and the same row's lower Doppler cells;
                        // lagging half: rows after n and the higher Doppler cells.
                        let rows_sum = |lo: usize, hi: usize, col: &Vec<f64>| {
                            if hi < lo {
                                0.0
                            } else {
                                col[(hi + 1) * nc + d] - col[lo * nc + d]
                            }
                        };
                        let lead_o = if n == 0 {
                            0.0
                        } else {
                            rows_sum(n.saturating_sub(wr), n - 1, co)
                        };
                        let lead_g = if n == 0 {
                            0.0
                        } else {
                            rows_sum(n.saturating_sub(gr), n - 1, cg)
                        };
                        let lag_o = rows_sum(n + 1, (n + wr).min(ns - 1), co);
                        let lag_g = rows_sum(n + 1, (n + gr).min(ns - 1), cg);
                        let side = if wd > gd {
                            (
                                row_sum(n, d, -(wd as isize), -(gd as isize) - 1),
                                row_sum(n, d, gd as isize + 1, wd as isize),
                            )
                        } else {
                            (0.0, 0.0)
                        };
                        let rows_cnt = |a: usize| a * (2 * wd + 1);
                        let g_cnt = |a: usize| a * (2 * gd + 1);
                        let lead_rows = n - n.saturating_sub(wr);
                        let lead_grows = n - n.saturating_sub(gr);
                        let lag_rows = (n + wr).min(ns - 1) - n;
                        let lag_grows = (n + gr).min(ns - 1) - n;
                        let c1 = rows_cnt(lead_rows) - g_cnt(lead_grows) + (wd - gd);
                        let c2 = rows_cnt(lag_rows) - g_cnt(lag_grows) + (wd - gd);
                        let m1 = (lead_o - lead_g + side.0) / c1.max(1) as f64;
                        let m2 = (lag_o - lag_g + side.1) / c2.max(1) as f64;
                        let z = match (c1 > 0, c2 > 0, cf.kind == CfarKind::Go) {
                            (true, true, true) => m1.max(m2),
                            (true, true, false) => m1.min(m2),
                            (true, false, _) => m1,
                            _ => m2,
                        };
                        self.cfar_alpha_half * z
                    }
                    CfarKind::Os => {
                        let s = &mut self.os_scratch;
                        s.clear();
                        let (lo, hi) = (n.saturating_sub(wr), (n + wr).min(ns - 1));
                        for nn in lo..=hi {
                            for dd in -(wd as isize)..=(wd as isize) {
                                if nn.abs_diff(n) <= gr && dd.unsigned_abs() <= gd {
                                    continue;
                                }
                                s.push(
                                    p[nn * nc + (d as isize + dd).rem_euclid(nc as isize) as usize],
                                );
                            }
                        }
                        let k = processing::os_rank_index(s.len(), cf.os_rank);
                        let (_, v, _) = s.select_nth_unstable_by(k, |a, b| a.total_cmp(b));
                        self.cfar_alpha[n] * *v as f64
                    }
                };
                if x > threshold {
                    self.hits.push((n, d));
                }
            }
        }
        if per_angle {
            self.hit_map.clear();
            self.hit_map.resize(ns * nc, false);
            for &(n, d) in &self.hits {
                self.hit_map[n * nc + d] = true;
            }
        }
    }
}
