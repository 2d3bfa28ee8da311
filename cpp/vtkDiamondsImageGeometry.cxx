#include "vtkDiamondsImageGeometry.h"

#include "vtkDiamondsArraySelection.h" // FilterText

#include "vtkAlgorithm.h"
#include "vtkImageData.h"
#include "vtkInformation.h"
#include "vtkInformationVector.h"
#include "vtkMatrix3x3.h"
#include "vtkStreamingDemandDrivenPipeline.h"

#include <algorithm>
#include <cmath>

namespace vtkDiamonds
{
namespace
{
bool BoxesTouch(const double a[6], const double b[6])
{
  for (int axis = 0; axis < 3; ++axis)
  {
    if (a[2 * axis] > b[2 * axis + 1] || a[2 * axis + 1] < b[2 * axis])
    {
      return false;
    }
  }
  return true;
}

// World bounds of an extent (identity direction matrix).
void ExtentBounds(const int extent[6], const double origin[3], const double spacing[3], double b[6])
{
  for (int axis = 0; axis < 3; ++axis)
  {
    const double lo = origin[axis] + extent[2 * axis] * spacing[axis];
    const double hi = origin[axis] + extent[2 * axis + 1] * spacing[axis];
    b[2 * axis] = std::min(lo, hi);
    b[2 * axis + 1] = std::max(lo, hi);
  }
}
} // namespace

//------------------------------------------------------------------------------
ImageGeometry::ImageGeometry(vtkImageData* input)
{
  input->GetExtent(this->Extent);
  input->GetDimensions(this->Dims);
  input->GetOrigin(this->Origin);
  input->GetSpacing(this->Spacing);
}

//------------------------------------------------------------------------------
bool IsAxisAligned(vtkImageData* input)
{
  const double* m = input->GetDirectionMatrix()->GetData();
  for (int i = 0; i < 9; ++i)
  {
    if (!(std::abs(m[i] - (i % 4 == 0 ? 1.0 : 0.0)) <= 1e-9))
    {
      return false;
    }
  }
  return true;
}

//------------------------------------------------------------------------------
bool CheckAxisAligned(vtkAlgorithm* filter, const FilterText& text, vtkImageData* input)
{
  if (!IsAxisAligned(input))
  {
    vtkErrorWithObjectMacro(filter,
      << "The input image is oriented (its direction matrix is not the identity); " << text.Name
      << " supports axis-aligned images only. Apply Resample To Image first.");
    return false;
  }
  return true;
}

//------------------------------------------------------------------------------
void WholeBounds(vtkInformationVector** inputVector, vtkImageData* input, double bounds[6])
{
  int extent[6];
  input->GetExtent(extent);
  vtkInformation* inInfo = inputVector[0]->GetInformationObject(0);
  if (inInfo && inInfo->Has(vtkStreamingDemandDrivenPipeline::WHOLE_EXTENT()))
  {
    inInfo->Get(vtkStreamingDemandDrivenPipeline::WHOLE_EXTENT(), extent);
  }
  ExtentBounds(extent, input->GetOrigin(), input->GetSpacing(), bounds);
}

//------------------------------------------------------------------------------
double WholeDiagonal(vtkInformationVector** inputVector, vtkImageData* input)
{
  double bounds[6];
  WholeBounds(inputVector, input, bounds);
  return std::sqrt(std::pow(bounds[1] - bounds[0], 2) + std::pow(bounds[3] - bounds[2], 2) +
    std::pow(bounds[5] - bounds[4], 2));
}

//------------------------------------------------------------------------------
bool CheckRegionOfInterest(vtkAlgorithm* filter, const double roi[6],
  vtkInformationVector** inputVector, vtkImageData* input, bool& touchesPiece)
{
  for (int axis = 0; axis < 3; ++axis)
  {
    if (!std::isfinite(roi[2 * axis]) || !std::isfinite(roi[2 * axis + 1]) ||
      roi[2 * axis] > roi[2 * axis + 1])
    {
      vtkErrorWithObjectMacro(filter,
        << "RegionOfInterest (" << roi[0] << ", " << roi[1] << ", " << roi[2] << ", " << roi[3]
        << ", " << roi[4] << ", " << roi[5]
        << ") must be finite with min <= max on every axis.");
      return false;
    }
  }
  // The region is checked against the whole image, not this process's piece.
  double wholeBounds[6];
  double pieceBounds[6];
  WholeBounds(inputVector, input, wholeBounds);
  int extent[6];
  input->GetExtent(extent);
  ExtentBounds(extent, input->GetOrigin(), input->GetSpacing(), pieceBounds);
  if (!BoxesTouch(roi, wholeBounds))
  {
    vtkErrorWithObjectMacro(filter,
      << "RegionOfInterest (" << roi[0] << ", " << roi[1] << ", " << roi[2] << ", " << roi[3]
      << ", " << roi[4] << ", " << roi[5] << ") lies outside the image bounds (" << wholeBounds[0]
      << ", " << wholeBounds[1] << ", " << wholeBounds[2] << ", " << wholeBounds[3] << ", "
      << wholeBounds[4] << ", " << wholeBounds[5] << ").");
    return false;
  }
  touchesPiece = BoxesTouch(roi, pieceBounds);
  return true;
}

//------------------------------------------------------------------------------
void RequestNoGhostLevels(vtkInformationVector** inputVector)
{
  vtkInformation* inInfo = inputVector[0]->GetInformationObject(0);
  inInfo->Set(vtkStreamingDemandDrivenPipeline::UPDATE_NUMBER_OF_GHOST_LEVELS(), 0);
}

} // namespace vtkDiamonds
