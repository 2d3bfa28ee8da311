// Internal to the Diamonds VTK module (not installed, not wrapped): the array a filter processes and
// how its messages name the filter and the input's arrays, and the parameter checks filters share.
#ifndef vtkDiamondsArraySelection_h
#define vtkDiamondsArraySelection_h

#include <string>

class vtkAlgorithm;
class vtkDataArray;
class vtkFieldData;
class vtkImageData;

namespace vtkDiamonds
{
// How a filter names itself and its array in messages, e.g. { "Adaptive Tetrahedra",
// "approximate", "approximates", "Scalars" }.
struct FilterText
{
  const char* Name;
  const char* Verb;
  const char* Verbs;
  const char* ArrayProperty;
};

// The array to process, from what the filter's GetInputArrayToProcess(0, ...) returned
// (`selected`, of `association`): that array, or the active point scalars when nothing is selected
// (ParaView leaves the selection empty until the input has been updated once). Reports an error on
// `filter` and returns nullptr when there is none, it is not point data, or it has more than one
// component.
vtkDataArray* SelectPointArray(vtkAlgorithm* filter, const FilterText& text, vtkImageData* input,
  vtkDataArray* selected, int association);

// The checks every image filter makes before meshing `input`, in order: an empty image ends the
// execution with empty outputs and is not an error (an empty piece when a parallel run has more ranks
// than image slabs); the image must be axis-aligned (CheckAxisAligned); the array to process is
// SelectPointArray's. Returns that array, or nullptr with `result` set to what RequestData returns
// (1 for an empty image, 0 after an error reported on `filter`).
vtkDataArray* ImageArrayToProcess(vtkAlgorithm* filter, const FilterText& text, vtkImageData* input,
  vtkDataArray* selected, int association, int& result);

// Whether `budget` (a filter's MaximumNumberOfTetrahedra) is usable: >= 0, 0 meaning no limit;
// reports an error on `filter` otherwise.
bool CheckBudget(vtkAlgorithm* filter, long long budget);

// Quoted, comma-separated names of the arrays of `data`, for messages.
std::string ArrayNames(vtkFieldData* data);

} // namespace vtkDiamonds

#endif
