//! Helpers of the core's unit tests.

/// A deterministic, roughly Gaussian sequence (sum of 12 uniforms), unit variance.
pub fn noise_sequence(n: usize, seed: u32) -> impl Iterator<Item = f32> {
    let mut state = seed;
    (0..n).map(move |_| {
        let mut sum = 0.0f32;
        for _ in 0..12 {
            state = state.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
            sum += (state >> 8) as f32 / (1u32 << 24) as f32;
        }
        sum - 6.0
    })
}

/// A deterministic xorshift sequence uniform on `[-sqrt 3, sqrt 3)`: unit variance.
pub fn uniform_noise(n: usize, seed: u32) -> impl Iterator<Item = f32> {
    let mut state = seed;
    (0..n).map(move |_| {
        state ^= state << 13;
        state ^= state >> 17;
        state ^= state << 5;
        let u = (state >> 8) as f32 / (1u32 << 24) as f32;
        (2.0 * u - 1.0) * 1.732
    })
}
