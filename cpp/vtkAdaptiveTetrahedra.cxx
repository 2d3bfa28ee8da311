#include "vtkAdaptiveTetrahedra.h"

#include "vtkDataArray.h"
#include "vtkDataSetAttributes.h"
#include "vtkDoubleArray.h"
#include "vtkFieldData.h"
#include "vtkIdTypeArray.h"
#include "vtkImageData.h"
#include "vtkInformation.h"
#include "vtkInformationVector.h"
#include "vtkObjectFactory.h"
#include "vtkStreamingDemandDrivenPipeline.h"
#include "vtkUnstructuredGrid.h"

// The module's internal helpers and the cxx bridge. Kept out of the public header: the VTK
// wrappers parse that one.
#include "vtkDiamondsArraySelection.h"
#include "vtkDiamondsHierarchyCache.h"
#include "vtkDiamondsImageGeometry.h"
#include "vtkDiamondsOutput.h"

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <optional>
#include <string>

vtkStandardNewMacro(vtkAdaptiveTetrahedra);

namespace
{
namespace bridge = diamonds::bridge;
using vtkDiamonds::OneValue;

const vtkDiamonds::FilterText Text = { "Adaptive Tetrahedra", "approximate", "approximates",
  "Scalars" };
} // namespace

class vtkAdaptiveTetrahedra::vtkInternals
{
public:
  // The mesh query does not read the samples again: no need to keep them.
  vtkDiamonds::HierarchyCache Cache{ vtkDiamonds::HierarchyCache::Use::Tetrahedra };
};

//------------------------------------------------------------------------------
vtkAdaptiveTetrahedra::vtkAdaptiveTetrahedra()
  : Tolerance(1.0)
  , MaximumNumberOfTetrahedra(0)
  , UseRegionOfInterest(0)
  , RegionOfInterest{ 0.0, 1.0, 0.0, 1.0, 0.0, 1.0 }
  , NumberOfHierarchyBuilds(0)
  , Internals(new vtkInternals)
{
  // Default: the active point scalars.
  this->SetInputArrayToProcess(
    0, 0, 0, vtkDataObject::FIELD_ASSOCIATION_POINTS, vtkDataSetAttributes::SCALARS);
}

//------------------------------------------------------------------------------
vtkAdaptiveTetrahedra::~vtkAdaptiveTetrahedra()
{
  delete this->Internals;
}

//------------------------------------------------------------------------------
int vtkAdaptiveTetrahedra::FillInputPortInformation(int, vtkInformation* info)
{
  info->Set(vtkAlgorithm::INPUT_REQUIRED_DATA_TYPE(), "vtkImageData");
  return 1;
}

//------------------------------------------------------------------------------
int vtkAdaptiveTetrahedra::RequestUpdateExtent(
  vtkInformation* request, vtkInformationVector** inputVector, vtkInformationVector* outputVector)
{
  if (!this->Superclass::RequestUpdateExtent(request, inputVector, outputVector))
  {
    return 0;
  }
  vtkDiamonds::RequestNoGhostLevels(inputVector);
  return 1;
}

//------------------------------------------------------------------------------
vtkIdType vtkAdaptiveTetrahedra::GetHierarchyMemorySize()
{
  return this->Internals->Cache.GetMemorySize();
}

//------------------------------------------------------------------------------
void vtkAdaptiveTetrahedra::ReleaseHierarchy()
{
  this->Internals->Cache.Release();
}

//------------------------------------------------------------------------------
int vtkAdaptiveTetrahedra::RequestData(
  vtkInformation*, vtkInformationVector** inputVector, vtkInformationVector* outputVector)
{
  vtkImageData* input = vtkImageData::GetData(inputVector[0]);
  vtkUnstructuredGrid* output = vtkUnstructuredGrid::GetData(outputVector);
  if (!input || !output)
  {
    vtkErrorMacro(<< "Adaptive Tetrahedra needs a vtkImageData input.");
    return 0;
  }
  output->Initialize(); // every error below leaves an empty output

  // ---- Parameters.
  if (!std::isfinite(this->Tolerance) || this->Tolerance < 0.0)
  {
    vtkErrorMacro(<< "Tolerance must be a finite number >= 0 (got " << this->Tolerance
                  << "); 0 reproduces every sample.");
    return 0;
  }
  if (this->MaximumNumberOfTetrahedra < 0)
  {
    vtkErrorMacro(<< "MaximumNumberOfTetrahedra must be >= 0 (got "
                  << this->MaximumNumberOfTetrahedra << "); 0 means no limit.");
    return 0;
  }

  // ---- Geometry.
  if (input->GetNumberOfPoints() == 0)
  {
    // Not an error: e.g. an empty piece when a parallel run has more ranks than image slabs.
    vtkDebugMacro(<< "The input image is empty; the output is empty.");
    return 1;
  }
  if (!vtkDiamonds::CheckAxisAligned(this, Text, input))
  {
    return 0;
  }

  // ---- The array to approximate.
  int association = vtkDataObject::FIELD_ASSOCIATION_POINTS;
  vtkDataArray* selected = this->GetInputArrayToProcess(0, inputVector, association);
  vtkDataArray* array = vtkDiamonds::SelectPointArray(this, Text, input, selected, association);
  if (!array)
  {
    return 0;
  }

  // ---- Hierarchy: built only when the array or the geometry changed.
  switch (this->Internals->Cache.Update(this, Text, input, array, 0.0, 0.8))
  {
    case vtkDiamonds::HierarchyCache::Status::Built:
      ++this->NumberOfHierarchyBuilds;
      break;
    case vtkDiamonds::HierarchyCache::Status::Kept:
      break;
    case vtkDiamonds::HierarchyCache::Status::Aborted:
      return 1;
    case vtkDiamonds::HierarchyCache::Status::Failed:
      return 0;
  }
  this->UpdateProgress(0.8);
  if (this->CheckAbort())
  {
    return 1;
  }

  // ---- Query.
  bridge::QuerySpec query;
  query.tolerance = this->Tolerance;
  query.max_tetrahedra = static_cast<std::size_t>(this->MaximumNumberOfTetrahedra);
  if (!vtkDiamonds::SetRegionOfInterest(
        this, this->UseRegionOfInterest, this->RegionOfInterest, inputVector, input, query))
  {
    return 0;
  }
  const bridge::Hierarchy& hierarchy = this->Internals->Cache.GetHierarchy();
  std::optional<rust::Box<bridge::MeshPlan>> plan;
  try
  {
    plan.emplace(hierarchy.plan_mesh(query));
  }
  catch (const rust::Error& e)
  {
    vtkErrorMacro(<< "Adaptive Tetrahedra query failed: " << e.what());
    return 0;
  }
  this->UpdateProgress(0.9);

  // ---- Output, written by the core into the arrays allocated here.
  double maxError = 0.0;
  std::string error;
  if (!vtkDiamonds::PlanToUnstructuredGrid(hierarchy, **plan, input, output, maxError, error))
  {
    output->Initialize();
    vtkErrorMacro(<< "Adaptive Tetrahedra could not write its output: " << error);
    return 0;
  }
  plan.reset(); // the split set, before the field data
  vtkFieldData* fieldData = output->GetFieldData();
  fieldData->PassData(input->GetFieldData());
  fieldData->AddArray(OneValue<vtkDoubleArray>("Tolerance", this->Tolerance));
  fieldData->AddArray(
    OneValue<vtkIdTypeArray>("NumberOfTetrahedra", output->GetNumberOfCells()));
  fieldData->AddArray(OneValue<vtkDoubleArray>("MaximumError", maxError));

  this->UpdateProgress(1.0);
  return 1;
}

//------------------------------------------------------------------------------
void vtkAdaptiveTetrahedra::PrintSelf(ostream& os, vtkIndent indent)
{
  this->Superclass::PrintSelf(os, indent);
  os << indent << "Tolerance: " << this->Tolerance << "\n";
  os << indent << "MaximumNumberOfTetrahedra: " << this->MaximumNumberOfTetrahedra << "\n";
  os << indent << "UseRegionOfInterest: " << (this->UseRegionOfInterest ? "On" : "Off") << "\n";
  os << indent << "RegionOfInterest: (" << this->RegionOfInterest[0] << ", "
     << this->RegionOfInterest[1] << ", " << this->RegionOfInterest[2] << ", "
     << this->RegionOfInterest[3] << ", " << this->RegionOfInterest[4] << ", "
     << this->RegionOfInterest[5] << ")\n";
  os << indent << "NumberOfHierarchyBuilds: " << this->NumberOfHierarchyBuilds << "\n";
  os << indent << "HierarchyMemorySize: " << this->GetHierarchyMemorySize() << "\n";
}
