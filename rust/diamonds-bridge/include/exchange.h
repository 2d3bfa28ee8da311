// The C++ half of the exchange channel of the Diamonds bridge.
//
// A distributed filter whose ranks share a computation (each holding the whole image, each doing
// its share) gives the Rust core this interface: every rank calls all_gather the same number of
// times, in the same order, and receives every rank's bytes. It is called only on the thread that
// called into the bridge (never from a worker thread), so an implementation may use the filter's
// vtkMultiProcessController directly.
//
// VTK-free on purpose, like progress.h: cxx compiles it into the Rust staticlib.
#pragma once

#include "rust/cxx.h"

#include <cstdint>

namespace diamonds
{
namespace bridge
{

class PieceExchange
{
public:
  virtual ~PieceExchange() = default;

  // Sends `bytes` to every rank and fills `all` with every rank's bytes concatenated in rank
  // order and `lengths` with their lengths (one per rank). Returns false when the ranks stop
  // instead (a rank failed or was aborted, agreed on by all: the core then returns an error). Must
  // not throw: an exception cannot cross the Rust frames above it.
  virtual bool all_gather(rust::Slice<const std::uint8_t> bytes, rust::Vec<std::uint8_t>& all,
    rust::Vec<std::uint64_t>& lengths) noexcept = 0;
};

} // namespace bridge
} // namespace diamonds
