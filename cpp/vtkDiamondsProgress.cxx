#include "vtkDiamondsProgress.h"

#include "vtkAlgorithm.h"

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

} // namespace vtkDiamonds
