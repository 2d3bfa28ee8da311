#include "vtkDiamondsProgress.h"

#include "vtkAlgorithm.h"
#include "vtkDemandDrivenPipeline.h"

#include <algorithm>

namespace vtkDiamonds
{
ProgressForwarder::ProgressForwarder(vtkAlgorithm* filter, double from, double to)
  : Filter(filter)
  , From(from)
  , To(to)
{
}

bool ProgressForwarder::report(double fraction) noexcept
{
  try
  {
    if (!this->Aborted && !this->Filter->CheckAbort())
    {
      this->Filter->UpdateProgress(
        this->From + (this->To - this->From) * std::min(std::max(fraction, 0.0), 1.0));
      this->Aborted = this->Filter->CheckAbort();
    }
    else
    {
      this->Aborted = true;
    }
  }
  catch (...)
  {
    this->Aborted = true; // an exception may not cross the Rust frames that called us
  }
  return !this->Aborted;
}

vtkMTimeType AbortLatch::Requested(vtkAlgorithm* filter)
{
  // Brought up to date by the executive before each execution (the filter's own time moves
  // during an execution: AbortExecute and AbortOutput are set through vtkSetMacro).
  auto* executive = vtkDemandDrivenPipeline::SafeDownCast(filter->GetExecutive());
  return executive ? executive->GetPipelineMTime() : filter->GetMTime();
}

AbortLatch::Execution::Execution(vtkAlgorithm* filter, AbortLatch& latch)
  : Filter(filter)
  , Latch(latch)
{
  if (latch.AbortedAt != 0 && Requested(filter) > latch.AbortedAt)
  {
    filter->SetAbortExecute(0);
  }
}

AbortLatch::Execution::~Execution()
{
  if (this->Filter->GetAbortOutput())
  {
    // Everything modified so far, the abort request itself included.
    this->Latch.AbortedAt = std::max(this->Filter->GetMTime(), Requested(this->Filter));
    return;
  }
  // Completed: an abort requested after the last check came too late for this execution and is
  // not kept for the next one.
  this->Latch.AbortedAt = 0;
  this->Filter->SetAbortExecute(0);
}

} // namespace vtkDiamonds
