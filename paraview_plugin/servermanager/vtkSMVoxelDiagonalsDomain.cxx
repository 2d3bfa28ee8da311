#include "vtkSMVoxelDiagonalsDomain.h"

#include "vtkMath.h"
#include "vtkObjectFactory.h"
#include "vtkPVDataInformation.h"
#include "vtkPVXMLElement.h"
#include "vtkSMPropertyHelper.h"

#include <cmath>

vtkStandardNewMacro(vtkSMVoxelDiagonalsDomain);

vtkSMVoxelDiagonalsDomain::vtkSMVoxelDiagonalsDomain()
{
  this->Mode = vtkSMBoundsDomain::APPROXIMATE_CELL_LENGTH;
}

vtkSMVoxelDiagonalsDomain::~vtkSMVoxelDiagonalsDomain() = default;

int vtkSMVoxelDiagonalsDomain::ReadXMLAttributes(vtkSMProperty* property, vtkPVXMLElement* element)
{
  if (!this->Superclass::ReadXMLAttributes(property, element))
  {
    return 0;
  }
  this->Mode = vtkSMBoundsDomain::APPROXIMATE_CELL_LENGTH;
  double voxelDiagonals = 1.0;
  if (element->GetScalarAttribute("voxel_diagonals", &voxelDiagonals))
  {
    if (!(voxelDiagonals > 0.0) || !std::isfinite(voxelDiagonals))
    {
      vtkErrorMacro("voxel_diagonals must be a finite number > 0 (got " << voxelDiagonals << ")");
      return 0;
    }
    this->VoxelDiagonals = voxelDiagonals;
  }
  return 1;
}

int vtkSMVoxelDiagonalsDomain::SetDefaultValues(vtkSMProperty* property, bool use_unchecked_values)
{
  vtkPVDataInformation* input = this->GetInputInformation();
  if (!input)
  {
    return 1; // As vtkSMBoundsDomain: no input yet, the XML default stays.
  }
  double bounds[6];
  input->GetBounds(bounds);
  double cellLength = 1.0;
  if (vtkMath::AreBoundsInitialized(bounds))
  {
    const double diagonal = std::sqrt((bounds[1] - bounds[0]) * (bounds[1] - bounds[0]) +
      (bounds[3] - bounds[2]) * (bounds[3] - bounds[2]) +
      (bounds[5] - bounds[4]) * (bounds[5] - bounds[4]));
    const double cells = static_cast<double>(input->GetNumberOfCells());
    cellLength = cells > 0.0 ? diagonal / std::cbrt(cells) : diagonal;
    if (!(cellLength > 0.0) || !std::isfinite(cellLength))
    {
      cellLength = 1.0;
    }
  }
  vtkSMPropertyHelper helper(property);
  helper.SetUseUnchecked(use_unchecked_values);
  helper.Set(0, this->VoxelDiagonals * cellLength);
  return 1;
}

void vtkSMVoxelDiagonalsDomain::PrintSelf(ostream& os, vtkIndent indent)
{
  this->Superclass::PrintSelf(os, indent);
  os << indent << "VoxelDiagonals: " << this->VoxelDiagonals << "\n";
}
