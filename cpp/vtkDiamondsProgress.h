// Internal to the Diamonds VTK module (not installed, not wrapped): progress and abort between a
// filter and the Rust core.
#ifndef vtkDiamondsProgress_h
#define vtkDiamondsProgress_h

#include "vtkDiamondsBridge.h"

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

} // namespace vtkDiamonds

#endif
