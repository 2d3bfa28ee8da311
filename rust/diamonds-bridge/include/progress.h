// The C++ half of the progress channel of the Diamonds bridge.
//
// The Rust core reports progress through this interface while it builds a diamond hierarchy.
// It is called only on the thread that called `build_hierarchy` (never from a worker thread),
// so an implementation may call vtkAlgorithm::UpdateProgress and CheckAbort directly.
//
// This header is VTK-free on purpose: cxx compiles it into the Rust staticlib, which knows
// nothing about VTK. The filter (cpp/vtkAdaptiveTetrahedra.cxx) derives from it.
#pragma once

namespace diamonds
{
namespace bridge
{

class ProgressObserver
{
public:
  virtual ~ProgressObserver() = default;

  // `fraction` is in [0, 1]. Return false to abort the build (the bridge then returns an error
  // and no hierarchy). Must not throw: an exception cannot cross the Rust frames above it.
  virtual bool report(double fraction) noexcept = 0;
};

} // namespace bridge
} // namespace diamonds
