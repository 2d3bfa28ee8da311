// Internal to the Diamonds VTK module (not installed, not wrapped): progress and abort between a
// filter and the Rust core.
#ifndef vtkDiamondsProgress_h
#define vtkDiamondsProgress_h

#include "vtkDiamondsBridge.h"

#include "vtkType.h"

class vtkAlgorithm;

namespace vtkDiamonds
{
// Forwards the core's build progress to UpdateProgress, mapped onto [From, To], and turns an
// abort request into `false` (which makes the core stop and return an error).
class ProgressForwarder final : public bridge::ProgressObserver
{
public:
  ProgressForwarder(vtkAlgorithm* filter, double from, double to);
  bool report(double fraction) noexcept override;

  bool Aborted = false;

private:
  vtkAlgorithm* Filter;
  double From;
  double To;
};

// An abort that lasts until the user changes something, kept by each filter.
//
// ParaView 5.11's VTK leaves AbortExecute set after an aborted execution (nothing in the pipeline
// or in ParaView's proxies clears it) and marks every output ABORTED, so that every later request
// for any output port executes the filter again. With the flag left set, each such execution
// aborts at once: the ports requested right after the abort, and renders, stay empty and cost
// nothing; but so would the next Apply. The latch clears the flag at the start of the first
// execution after the filter or its input changed (a property set, upstream modified, or the
// flag cleared by hand): changing a property and applying again recomputes.
class AbortLatch
{
public:
  // Begins an execution of `filter` on construction (clearing a stale abort) and, on destruction,
  // remembers whether it ended aborted (AbortOutput, which CheckAbort sets and the executive reads
  // to empty the outputs and mark them ABORTED); an execution that completed clears the flag (an
  // abort requested after its last check came too late for it, and is not one for the next).
  class Execution
  {
  public:
    Execution(vtkAlgorithm* filter, AbortLatch& latch);
    ~Execution();
    Execution(const Execution&) = delete;
    Execution& operator=(const Execution&) = delete;

  private:
    vtkAlgorithm* Filter;
    AbortLatch& Latch;
  };

private:
  // The pipeline modification time of `filter` (its own and its inputs') when this execution
  // was requested.
  static vtkMTimeType Requested(vtkAlgorithm* filter);
  // When the last execution ended aborted: the time of the last modification by then, else 0.
  vtkMTimeType AbortedAt = 0;
};

} // namespace vtkDiamonds

#endif
