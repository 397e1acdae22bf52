//! The sRGB transfer function, both ways, and linear values to the 8-bit sRGB bytes a PNG stores
//! (found by table, the same bytes as by the power).

/// The sRGB transfer function of one linear channel, clamped to [0, 1] (NaN counts as 0).
#[inline]
pub fn srgb_encode(linear: f32) -> f32 {
    let c = if linear.is_nan() { 0.0 } else { linear.clamp(0.0, 1.0) };
    // `libm`'s power, the same on every platform: the 8-bit thresholds are found from it, and a
    // PNG downloaded from the browser build has the bytes `lancer render` writes.
    if c <= 0.003_130_8 { 12.92 * c } else { 1.055 * libm::powf(c, 1.0 / 2.4) - 0.055 }
}

/// The sRGB transfer function undone: an encoded channel in [0, 1] to linear.
pub fn srgb_decode(c: f32) -> f32 {
    if c <= 0.04045 { c / 12.92 } else { libm::powf((c + 0.055) / 1.055, 2.4) }
}

/// One linear channel as the 8-bit sRGB value a PNG stores: [`srgb_encode`] rounded to the
/// nearest step, found by its thresholds (a bucket of the float's bits, then one comparison)
/// instead of a power: the same byte.
#[inline]
pub fn srgb8(linear: f32) -> u8 {
    srgb8_in(linear, srgb8_buckets())
}

/// One linear channel as an 8-bit sRGB value: the encoded value rounded to the nearest step.
#[inline]
fn srgb8_of(linear: f32) -> u8 {
    (srgb_encode(linear) * 255.0 + 0.5) as u8
}

/// For each 8-bit value `k` from 1 to 255, the smallest linear value in [0, 1] that
/// [`srgb8_of`] takes to `k` or more: the byte of a channel is the number of thresholds at or
/// below it. [`srgb8_of`] never decreases as its input grows, so a search over the bits of the
/// non-negative floats (ordered as their values) finds each threshold exactly.
fn srgb8_thresholds() -> &'static [f32; 255] {
    static TABLE: std::sync::OnceLock<[f32; 255]> = std::sync::OnceLock::new();
    TABLE.get_or_init(|| {
        std::array::from_fn(|k| {
            let k = k as u8 + 1;
            let (mut lo, mut hi) = (0u32, 1.0f32.to_bits());
            // Invariant: srgb8_of(lo) < k <= srgb8_of(hi).
            while hi - lo > 1 {
                let mid = lo + (hi - lo) / 2;
                if srgb8_of(f32::from_bits(mid)) >= k { hi = mid } else { lo = mid }
            }
            f32::from_bits(hi)
        })
    })
}

/// How many low bits of a float in [0, 1) its bucket of [`Buckets`] drops: the buckets are
/// about 2⁻⁷ of their value wide, narrower than the gap between two thresholds anywhere in
/// [0, 1), so a bucket holds at most one threshold (a test checks every bucket).
const BUCKET_SHIFT: u32 = 16;

/// The thresholds of [`srgb8_thresholds`] by bucket of float bits: for each bucket, the byte of
/// its lowest float and the one threshold inside it (infinity if none).
struct Buckets {
    base: Vec<u8>,
    next: Vec<f32>,
}

fn srgb8_buckets() -> &'static Buckets {
    static TABLE: std::sync::OnceLock<Buckets> = std::sync::OnceLock::new();
    TABLE.get_or_init(|| {
        let thresholds = srgb8_thresholds();
        let count = (1.0f32.to_bits() >> BUCKET_SHIFT) as usize;
        let (mut base, mut next) = (Vec::with_capacity(count), Vec::with_capacity(count));
        for b in 0..count as u32 {
            let (lo, hi) = (f32::from_bits(b << BUCKET_SHIFT), f32::from_bits(((b + 1) << BUCKET_SHIFT) - 1));
            let below = thresholds.partition_point(|&t| t <= lo);
            base.push(below as u8);
            next.push(thresholds.get(below).copied().filter(|&t| t <= hi).unwrap_or(f32::INFINITY));
        }
        Buckets { base, next }
    })
}

/// [`srgb8`] with the table at hand.
#[inline]
fn srgb8_in(c: f32, buckets: &Buckets) -> u8 {
    if c >= 1.0 {
        return 255;
    }
    // NaN and everything at or below 0 (no threshold is) give 0, as `srgb_encode` takes them.
    if c.is_nan() || c <= 0.0 {
        return 0;
    }
    let b = (c.to_bits() >> BUCKET_SHIFT) as usize;
    buckets.base[b] + u8::from(c >= buckets.next[b])
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_threshold_search_gives_the_bytes_of_the_curve() {
        // Every float near a threshold (where a mistake would show), a sweep through all the
        // floats in [0, 1] and beyond, and the special values: the same byte as encoding it.
        let mut values: Vec<f32> = vec![0.0, -0.0, 1.0, -1.0, 2.0, f32::NAN, f32::INFINITY, f32::NEG_INFINITY, 1e-45];
        for &t in srgb8_thresholds() {
            let bits = t.to_bits();
            values.extend((bits.saturating_sub(64)..bits + 64).map(f32::from_bits));
        }
        values.extend((0..=1.5f32.to_bits()).step_by(997).map(f32::from_bits));
        let bytes: Vec<u8> = values.iter().map(|&v| srgb8(v)).collect();
        for (v, got) in values.iter().zip(&bytes) {
            assert_eq!(*got, srgb8_of(*v), "{v} ({:#x})", v.to_bits());
        }
        // Every byte is reached.
        let reached: std::collections::BTreeSet<u8> = bytes.iter().copied().collect();
        assert_eq!(reached.len(), 256);
    }

    #[test]
    fn every_bucket_holds_at_most_one_threshold() {
        // What the bucket lookup relies on: a second threshold in a bucket would be missed.
        let thresholds = srgb8_thresholds();
        let mut per_bucket = std::collections::BTreeMap::new();
        for t in thresholds {
            *per_bucket.entry(t.to_bits() >> BUCKET_SHIFT).or_insert(0) += 1;
        }
        assert!(per_bucket.values().all(|&n| n == 1), "{per_bucket:?}");
        assert_eq!(per_bucket.len(), 255);
    }
}
