#include "vtkDiamondsArraySelection.h"

#include "vtkDiamondsImageGeometry.h"

#include "vtkAlgorithm.h"
#include "vtkCellData.h"
#include "vtkDataArray.h"
#include "vtkDataObject.h"
#include "vtkFieldData.h"
#include "vtkImageData.h"
#include "vtkInformation.h"
#include "vtkPointData.h"

#include <sstream>

namespace vtkDiamonds
{
std::string ArrayNames(vtkFieldData* data)
{
  std::ostringstream names;
  for (int i = 0; i < data->GetNumberOfArrays(); ++i)
  {
    const char* name = data->GetArrayName(i);
    names << (i ? ", " : "") << '"' << (name ? name : "") << '"';
  }
  return names.str();
}

//------------------------------------------------------------------------------
bool CheckBudget(vtkAlgorithm* filter, long long budget)
{
  if (budget < 0)
  {
    vtkErrorWithObjectMacro(filter,
      << "MaximumNumberOfTetrahedra must be >= 0 (got " << budget << "); 0 means no limit.");
    return false;
  }
  return true;
}

//------------------------------------------------------------------------------
vtkDataArray* ImageArrayToProcess(vtkAlgorithm* filter, const FilterText& text, vtkImageData* input,
  vtkDataArray* selected, int association, int& result)
{
  result = 0;
  if (input->GetNumberOfPoints() == 0)
  {
    vtkDebugWithObjectMacro(filter, << "The input image is empty; the output is empty.");
    result = 1;
    return nullptr;
  }
  if (!CheckAxisAligned(filter, text, input))
  {
    return nullptr;
  }
  return SelectPointArray(filter, text, input, selected, association);
}

//------------------------------------------------------------------------------
vtkDataArray* SelectPointArray(vtkAlgorithm* filter, const FilterText& text, vtkImageData* input,
  vtkDataArray* selected, int association)
{
  vtkDataArray* array = selected;
  if (!array)
  {
    vtkInformation* arrayInfo = filter->GetInputArrayInformation(0);
    const char* requested = arrayInfo->Has(vtkDataObject::FIELD_NAME())
      ? arrayInfo->Get(vtkDataObject::FIELD_NAME())
      : nullptr;
    if (requested && *requested)
    {
      vtkErrorWithObjectMacro(filter,
        << "The input has no point-data array named \"" << requested
        << "\". Point arrays: " << ArrayNames(input->GetPointData()) << ".");
      return nullptr;
    }
    // Nothing selected (ParaView leaves the selection empty until the input has been updated
    // once): use the active point scalars.
    array = input->GetPointData()->GetScalars();
    association = vtkDataObject::FIELD_ASSOCIATION_POINTS;
  }
  if (!array)
  {
    if (input->GetCellData()->GetNumberOfArrays() > 0)
    {
      vtkErrorWithObjectMacro(filter,
        << "The input has no point scalars, only cell data (" << ArrayNames(input->GetCellData())
        << "). " << text.Name << " " << text.Verbs
        << " a point-data array: apply Cell Data to Point Data first.");
    }
    else
    {
      vtkErrorWithObjectMacro(filter,
        << "The input has no point scalars: select a point-data array (" << text.ArrayProperty
        << ").");
    }
    return nullptr;
  }
  const std::string name = array->GetName() ? array->GetName() : "";
  if (association != vtkDataObject::FIELD_ASSOCIATION_POINTS)
  {
    vtkErrorWithObjectMacro(filter,
      << "Array \"" << name << "\" is not point data. " << text.Name << " " << text.Verbs
      << " a point-data array: apply Cell Data to Point Data first.");
    return nullptr;
  }
  if (array->GetNumberOfComponents() != 1)
  {
    vtkErrorWithObjectMacro(filter,
      << "Array \"" << name << "\" has " << array->GetNumberOfComponents() << " components; "
      << text.Name
      << " needs a single-component array. Use Calculator to extract a component (e.g. " << name
      << "_X) or the magnitude (mag(" << name << ")).");
    return nullptr;
  }
  return array;
}

} // namespace vtkDiamonds
