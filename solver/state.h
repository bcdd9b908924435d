#pragma once
// A solver's state as bytes, for checkpoints (render/checkpoint.h): what advance()
// changes, written by Solver::save() and read back by Solver::restore(), so that a
// restored solver goes on bit-identically.
//
// Values are raw, in this machine's byte order (the checkpoint file records the order
// and refuses another). Sections begin with a tag, and vectors carry their length,
// which must be the length the restoring solver already has: bytes of another method,
// scene or option set are refused (StateError) before anything is allocated, and
// every read is bounds-checked.
//
// Call order: StateWriter: tag(), put(), ... then bytes(). StateReader(bytes):
// expect() the same tags and read the same values in the same order, then finish().
#include "sampling/rng.h"
#include "scenes/scene.h"

#include <cmath>
#include <cstdint>
#include <cstring>
#include <stdexcept>
#include <string>
#include <string_view>
#include <type_traits>
#include <vector>

namespace raybundle::solver {

// Bytes that are not what the restoring solver would have saved.
struct StateError : std::runtime_error {
    using std::runtime_error::runtime_error;
};

class StateWriter {
public:
    void tag(std::string_view name) {
        put(static_cast<std::uint64_t>(name.size()));
        bytes_.append(name);
    }
    void put(std::uint64_t v) { raw(&v, sizeof v); }
    void put(long v) {
        const auto x = static_cast<std::int64_t>(v);
        raw(&x, sizeof x);
    }
    void put(double v) { raw(&v, sizeof v); }
    void put(bool v) { put(static_cast<std::uint64_t>(v)); }
    void put(const scenes::Vec3& v) { raw(v.data(), 3 * sizeof(double)); }
    void put(const scenes::Rgb& v) { raw(v.data(), 3 * sizeof(double)); }
    void put(const sampling::Rng& rng) {
        for (std::uint64_t s : rng.state()) put(s);
    }
    template <class T>
    void put(const std::vector<T>& v) {
        put(static_cast<std::uint64_t>(v.size()));
        for (const T& x : v) put(x);
    }
    const std::string& bytes() const { return bytes_; }

private:
    void raw(const void* p, std::size_t n) { bytes_.append(static_cast<const char*>(p), n); }
    std::string bytes_;
};

class StateReader {
public:
    explicit StateReader(std::string_view bytes) : bytes_(bytes) {}

    // The next section must be `name`.
    void expect(std::string_view name) {
        const std::uint64_t n = u64();
        if (n != name.size() || left() < n || bytes_.substr(at_, n) != name)
            throw StateError("expected the section '" + std::string(name) + "'");
        at_ += n;
    }
    std::uint64_t u64() { return value<std::uint64_t>(); }
    long i64() { return static_cast<long>(value<std::int64_t>()); }
    // A state never holds a value that is not finite: one that does is damaged (or
    // forged), and would end the run in NaNs after the whole solve.
    double f64() { return finite(value<double>()); }
    bool flag() { return u64() != 0; }
    void get(std::uint64_t& v) { v = u64(); }
    void get(long& v) { v = i64(); }
    void get(double& v) { v = f64(); }
    void get(bool& v) { v = flag(); }
    void get(scenes::Vec3& v) {
        for (int k = 0; k < 3; ++k) v[k] = f64();
    }
    void get(scenes::Rgb& v) {
        for (int k = 0; k < 3; ++k) v[k] = f64();
    }
    // xoshiro256** never reaches the all-zero state, and would stay there.
    void get(sampling::Rng& rng) {
        sampling::Rng::State s;
        std::uint64_t any = 0;
        for (auto& x : s) any |= (x = u64());
        if (any == 0) throw StateError("a random generator's state of zeros");
        rng.set_state(s);
    }
    // A vector of the length `v` has now.
    template <class T>
    void get(std::vector<T>& v) {
        const std::uint64_t n = u64();
        if (n != v.size())
            throw StateError("a vector of " + std::to_string(n) + " values where " + std::to_string(v.size()) +
                             " were expected");
        for (T& x : v) get(x);
    }
    // Every byte read.
    void finish() const {
        if (left() != 0) throw StateError(std::to_string(left()) + " bytes left over");
    }
    // The bytes not yet read.
    std::size_t left() const { return bytes_.size() - at_; }

private:
    static double finite(double x) {
        if (!std::isfinite(x)) throw StateError("a value that is not finite");
        return x;
    }
    template <class T>
    T value() {
        static_assert(std::is_trivially_copyable_v<T>);
        T v;
        raw(&v, sizeof v);
        return v;
    }
    void raw(void* p, std::size_t n) {
        if (left() < n) throw StateError("the state ends early");
        std::memcpy(p, bytes_.data() + at_, n);
        at_ += n;
    }
    std::string_view bytes_;
    std::size_t at_ = 0;
};

}  // namespace raybundle::solver
