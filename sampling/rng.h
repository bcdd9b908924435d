#pragma once
// A seeded, splittable pseudo-random generator (xoshiro256**, seeded by SplitMix64).
// Streams are split by index, never by timing, so results do not depend on the
// number of threads: stream k of seed s is the same sequence on every machine.
//
// Call order: Rng(seed, stream) -> uniform()/next_u64() ... ; state()/set_state() to
// save a generator and go on with it later (checkpoints).
//
// Draw into named variables, one declaration after another, never as two arguments of
// one call: f(rng.uniform(), rng.uniform()) leaves the order to the compiler (GCC goes
// right to left, Clang left to right), and the same seed would give another result
// with another compiler. Where a call of that kind was replaced, the variables keep
// the order GCC gave it, so that results stayed bit-identical ("y first").
#include <array>
#include <cstdint>

namespace raybundle::sampling {

class Rng {
public:
    explicit Rng(std::uint64_t seed = 0, std::uint64_t stream = 0) {
        std::uint64_t x = seed ^ (0x9E3779B97F4A7C15ull * (stream + 1));
        for (auto& s : s_) s = splitmix64(x);
    }

    std::uint64_t next_u64() {
        const std::uint64_t result = rotl(s_[1] * 5, 7) * 9;
        const std::uint64_t t = s_[1] << 17;
        s_[2] ^= s_[0];
        s_[3] ^= s_[1];
        s_[1] ^= s_[2];
        s_[0] ^= s_[3];
        s_[2] ^= t;
        s_[3] = rotl(s_[3], 45);
        return result;
    }

    // Uniform in [0, 1) with 53 random bits.
    double uniform() { return static_cast<double>(next_u64() >> 11) * 0x1.0p-53; }

    // The whole state: a generator given it goes on with the same sequence.
    using State = std::array<std::uint64_t, 4>;
    State state() const { return {s_[0], s_[1], s_[2], s_[3]}; }
    void set_state(const State& s) {
        for (int k = 0; k < 4; ++k) s_[k] = s[static_cast<std::size_t>(k)];
    }

private:
    static std::uint64_t rotl(std::uint64_t x, int k) { return (x << k) | (x >> (64 - k)); }
    static std::uint64_t splitmix64(std::uint64_t& x) {
        std::uint64_t z = (x += 0x9E3779B97F4A7C15ull);
        z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
        z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
        return z ^ (z >> 31);
    }
    std::uint64_t s_[4];
};

}  // namespace raybundle::sampling
