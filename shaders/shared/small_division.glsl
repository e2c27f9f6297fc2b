// Unsigned integer quotients without an integer division instruction: lavapipe (x86 has no vector
// integer division) divides lane by lane, and runs both sides of a branch whose condition differs
// between lanes (so a per-lane fallback to integer division costs as much as dividing).
#ifndef COFUSION_SMALL_DIVISION_GLSL
#define COFUSION_SMALL_DIVISION_GLSL

// a / b (b > 0) through float, exact for a < SMALL_QUOTIENT_LIMIT (2^20, the caller's guarantee):
// (a + 0.5) / b lies at least 0.5 / b from an integer, and the error of (a + 0.5) * (1 / b) in
// float is at most about 3.6e-7 relative (Vulkan allows 2.5 ulp for the division, 0.5 for the
// product), which stays below that while a * 3.6e-7 < 0.5.
uint small_quotient(uint a, uint b) { return uint((float(a) + 0.5) * (1.0 / float(b))); }

// ceil(a / b) (b > 0) by integer division, for any a (the division first: a + b - 1 could wrap);
// for counts the GPU holds, once per dispatch, not per lane.
uint ceil_quotient(uint a, uint b) { return a / b + uint(a % b != 0u); }

#endif
