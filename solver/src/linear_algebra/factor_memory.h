#pragma once
// Whether a factor's values fit in the memory the machine has left, checked between the analysis
// (which knows how many entries L has) and the numeric factorization (which allocates them). A
// factor too large for the memory gets a clear error instead of the system's out-of-memory killer,
// which ends the process with nothing said (an editor asked to solve a 13-million-triangle scan on
// every vertex, say, on a laptop).
#include <cstdint>
#include <optional>
#include <string>

namespace hdeform::detail {

// The bytes the numeric factorization allocates at its peak for `nonzeros` entries of L: the
// values by rows and by columns, in double (a single-precision factor's rows are floats, but its
// columns are rounded beside their doubles, so its peak is the same).
std::uint64_t factor_value_bytes(std::size_t nonzeros);

// The system's estimate of the memory available without swapping (Linux: MemAvailable), or
// less where the process's memory cgroup (a container, a systemd unit) allows less; nullopt where
// neither can be read.
std::optional<std::uint64_t> available_memory_bytes();

// Throws SolveError naming the unknowns, what the factor needs and what is available when
// `needed` exceeds `available`; nothing when `available` is unknown.
void check_factor_memory(std::int64_t unknowns, std::uint64_t needed, std::optional<std::uint64_t> available);

}  // namespace hdeform::detail
