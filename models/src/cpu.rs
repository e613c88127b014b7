//! Run-time choice of the SIMD kernels (ray packets, radar baseband spreading).
//!
//! The 8-lane AVX2 + FMA kernels run where the CPU has both features; elsewhere the portable code
//! (4-lane packets of plain `f32` arithmetic, scalar spreading) computes the same quantities. The
//! environment variable `OSIRIS_SIMD=portable` forces the portable code on any CPU: to check that
//! both give the same results (`.ci/run` runs every osiris-models test binary that way) or to rule
//! the SIMD kernels out when chasing a difference. It is read once per process.

use std::sync::OnceLock;

/// Environment variable that selects the kernels: `portable` forces the portable code; unset or
/// any other value lets the CPU decide.
pub const SIMD_ENV: &str = "OSIRIS_SIMD";

/// Whether the AVX2 + FMA kernels may run: the CPU has both features and [`SIMD_ENV`] is not
/// `portable`. Cached after the first call.
#[inline]
pub fn avx2_fma() -> bool {
    static AVX2_FMA: OnceLock<bool> = OnceLock::new();
    *AVX2_FMA.get_or_init(|| !portable_forced() && cpu_has_avx2_fma())
}

/// Whether [`SIMD_ENV`] asks for the portable code.
pub fn portable_forced() -> bool {
    std::env::var_os(SIMD_ENV).is_some_and(|v| v.eq_ignore_ascii_case("portable"))
}

#[cfg(target_arch = "x86_64")]
fn cpu_has_avx2_fma() -> bool {
    std::is_x86_feature_detected!("avx2") && std::is_x86_feature_detected!("fma")
}

#[cfg(not(target_arch = "x86_64"))]
fn cpu_has_avx2_fma() -> bool {
    false
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_environment_can_force_the_portable_kernels() {
        if portable_forced() {
            assert!(!avx2_fma());
        } else {
            assert_eq!(avx2_fma(), cpu_has_avx2_fma());
        }
    }
}
