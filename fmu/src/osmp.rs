//! OSMP binary-variable helpers: buffer addresses split into two signed 32-bit Integers plus a
//! size (OSMP 1.6.0 §"Notional binary variables").

/// Split an address into OSMP `(base.lo, base.hi)`: the low and high 32 bits, each bit-cast to
/// `i32`.
pub fn split_address(addr: usize) -> (i32, i32) {
    let a = addr as u64;
    (a as u32 as i32, (a >> 32) as u32 as i32)
}

/// Join OSMP `(base.lo, base.hi)` into an address (`hi` must be 0 on 32-bit hosts; `None` if the
/// address does not fit a pointer).
pub fn join_address(lo: i32, hi: i32) -> Option<usize> {
    let a = (u64::from(hi as u32) << 32) | u64::from(lo as u32);
    usize::try_from(a).ok()
}

/// The `[base.lo, base.hi, size]` triple publishing `buf` (0/0/0 for an empty buffer).
/// Errors if the buffer is 2 GiB or larger (the size is an `i32`).
pub fn publish(buf: &[u8]) -> Result<[i32; 3], String> {
    if buf.is_empty() {
        return Ok([0; 3]);
    }
    let size = i32::try_from(buf.len()).map_err(|_| {
        format!(
            "the buffer has {} bytes, more than an OSMP size (i32) can carry",
            buf.len()
        )
    })?;
    let (lo, hi) = split_address(buf.as_ptr() as usize);
    Ok([lo, hi, size])
}

/// The buffer a `[base.lo, base.hi, size]` triple names: `Ok(None)` for "no buffer" (address 0
/// or size ≤ 0), `Ok(Some((address, length in bytes)))` otherwise, `Err` if the address does not
/// fit a pointer.
pub fn address(triple: [i32; 3]) -> Result<Option<(usize, usize)>, String> {
    let [lo, hi, size] = triple;
    let Some(addr) = join_address(lo, hi) else {
        return Err(format!(
            "address {hi:#x}:{lo:#x} does not fit a pointer on this host"
        ));
    };
    if addr == 0 || size <= 0 {
        return Ok(None);
    }
    Ok(Some((addr, size as usize)))
}

/// View the importer's buffer.
///
/// # Safety
/// `addr` must point to `len` readable bytes that stay valid and unmodified for the returned
/// lifetime (OSMP guarantees this for an input until the end of the next `fmi2DoStep`, for the
/// Config until `fmi2ExitInitializationMode` returns). `addr` is non-zero and `len` ≤ `i32::MAX`
/// when they come from [`address`].
pub unsafe fn bytes<'a>(addr: usize, len: usize) -> &'a [u8] {
    // SAFETY: upheld by the caller; `u8` has alignment 1 and `len` fits `isize`.
    unsafe { std::slice::from_raw_parts(addr as *const u8, len) }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn address_round_trip_with_signed_halves() {
        for addr in [
            0usize,
            1,
            0x7fff_ffff,
            0x8000_0000,
            0xffff_ffff,
            0x7f12_8000_0001,
            usize::MAX,
        ] {
            let (lo, hi) = split_address(addr);
            assert_eq!(join_address(lo, hi), Some(addr), "{addr:#x}");
        }
        assert_eq!(split_address(0x8000_0000), (i32::MIN, 0));
        assert_eq!(split_address(0x1_ffff_ffff), (-1, 1));
    }

    #[test]
    fn no_buffer_cases() {
        assert_eq!(address([0, 0, 10]), Ok(None));
        assert_eq!(address([16, 0, 0]), Ok(None));
        assert_eq!(address([16, 0, -5]), Ok(None));
        assert_eq!(address([16, 0, 5]), Ok(Some((16, 5))));
        assert_eq!(publish(&[]), Ok([0, 0, 0]));
    }
}
