#include "vtkViewDependentTetrahedra.h"

#include "vtkCellData.h"
#include "vtkDataArray.h"
#include "vtkDataSetAttributes.h"
#include "vtkDiamondsProgress.h"
#include "vtkDiamondsVisibilitySort.h"
#include "vtkDoubleArray.h"
#include "vtkFieldData.h"
#include "vtkIdTypeArray.h"
#include "vtkImageData.h"
#include "vtkInformation.h"
#include "vtkInformationVector.h"
#include "vtkObjectFactory.h"
#include "vtkTypeUInt64Array.h"
#include "vtkUnsignedCharArray.h"
#include "vtkUnstructuredGrid.h"

// The module's internal helpers and the cxx bridge (kept out of the public header).
#include "vtkDiamondsArraySelection.h"
#include "vtkDiamondsHierarchyCache.h"
#include "vtkDiamondsImageGeometry.h"
#include "vtkDiamondsOutput.h"
#include "vtkDiamondsPieces.h"

#include <algorithm>
#include <cmath>
#include <optional>
#include <string>
#include <utility>

vtkStandardNewMacro(vtkViewDependentTetrahedra);

namespace
{
namespace bridge = diamonds::bridge;
using vtkDiamonds::OneValue;

const vtkDiamonds::FilterText Text = { "View Dependent Tetrahedra", "mesh", "meshes",
  "Scalars" };

} // namespace

class vtkViewDependentTetrahedra::vtkInternals
{
public:
  // Clears a stale abort (see AbortLatch).
  vtkDiamonds::AbortLatch Abort;
  vtkDiamonds::HierarchyCache Cache{ vtkDiamonds::HierarchyCache::Use::Tetrahedra };
  // The split and merge queues' state of the last execution (belongs to the cached hierarchy).
  std::optional<rust::Box<bridge::ViewMesh>> View;
  // The hierarchy build and budget of the last budget warning: said once for them, not at every
  // camera move (the Adaptive Volume representation executes the filter at every frame).
  std::pair<vtkIdType, vtkIdType> BudgetWarned{ -1, -1 };
};

//------------------------------------------------------------------------------
vtkViewDependentTetrahedra::vtkViewDependentTetrahedra()
  : CameraPosition{ 0.0, 0.0, 1.0 }
  , CameraFocalPoint{ 0.0, 0.0, 0.0 }
  , CameraViewUp{ 0.0, 1.0, 0.0 }
  , ViewAngle(30.0)
  , ViewportSize{ 1024, 768 }
  , PixelTolerance(1.0)
  , MaximumNumberOfTetrahedra(1000000)
  , SortCells(0)
  , NumberOfHierarchyBuilds(0)
  , MeshLocalPiece(false)
  , Internals(new vtkInternals)
{
  this->SetInputArrayToProcess(
    0, 0, 0, vtkDataObject::FIELD_ASSOCIATION_POINTS, vtkDataSetAttributes::SCALARS);
}

//------------------------------------------------------------------------------
vtkViewDependentTetrahedra::~vtkViewDependentTetrahedra()
{
  delete this->Internals;
}

//------------------------------------------------------------------------------
int vtkViewDependentTetrahedra::FillInputPortInformation(int, vtkInformation* info)
{
  info->Set(vtkAlgorithm::INPUT_REQUIRED_DATA_TYPE(), "vtkImageData");
  return 1;
}

//------------------------------------------------------------------------------
int vtkViewDependentTetrahedra::RequestData(
  vtkInformation*, vtkInformationVector** inputVector, vtkInformationVector* outputVector)
try
{
  const vtkDiamonds::AbortLatch::Execution execution(this, this->Internals->Abort);
  vtkImageData* input = vtkImageData::GetData(inputVector[0]);
  vtkUnstructuredGrid* output = vtkUnstructuredGrid::GetData(outputVector);
  if (!input || !output)
  {
    vtkErrorMacro(<< "View Dependent Tetrahedra needs a vtkImageData input.");
    return 0;
  }
  output->Initialize(); // every error below leaves an empty output
  vtkDiamondsVisibilitySort::Unmark(output); // marked again when sorted below

  // ---- Parameters (the camera itself is checked by the core).
  if (!std::isfinite(this->PixelTolerance) || this->PixelTolerance < 0.0)
  {
    vtkErrorMacro(<< "PixelTolerance must be a finite number >= 0 (got " << this->PixelTolerance
                  << ").");
    return 0;
  }
  if (!vtkDiamonds::CheckBudget(this, this->MaximumNumberOfTetrahedra))
  {
    return 0;
  }
  if (this->SortCells < 0 || this->SortCells > 2)
  {
    vtkErrorMacro(<< "SortCells must be 0 (none), 1 (back to front) or 2 (front to back), not "
                  << this->SortCells << ".");
    return 0;
  }
  if (this->ViewportSize[0] < 1 || this->ViewportSize[1] < 1)
  {
    vtkErrorMacro(<< "ViewportSize must be at least 1 x 1 pixels (got " << this->ViewportSize[0]
                  << " x " << this->ViewportSize[1] << ").");
    return 0;
  }
  if (!this->MeshLocalPiece && vtkDiamonds::Pieces::DistributedController())
  {
    vtkErrorMacro(<< "View Dependent Tetrahedra runs on one process only (it has more than one "
                     "MPI rank): show the image with the Adaptive Volume representation instead, "
                     "or run this filter in a serial pvpython.");
    return 0;
  }

  // ---- Input, hierarchy (built when the array or the geometry changed) and the view state.
  int association = vtkDataObject::FIELD_ASSOCIATION_POINTS;
  vtkDataArray* selected = this->GetInputArrayToProcess(0, inputVector, association);
  int result = 0;
  vtkDataArray* array =
    vtkDiamonds::ImageArrayToProcess(this, Text, input, selected, association, result);
  if (!array ||
    !this->Internals->Cache.Prepare(
      this, Text, input, array, 0.0, 0.6, this->NumberOfHierarchyBuilds, result))
  {
    return result;
  }
  const bridge::Hierarchy& hierarchy = this->Internals->Cache.GetHierarchy();
  auto& view = this->Internals->View;
  bridge::ViewSpec spec;
  std::copy_n(this->CameraPosition, 3, spec.position.begin());
  std::copy_n(this->CameraFocalPoint, 3, spec.focal_point.begin());
  std::copy_n(this->CameraViewUp, 3, spec.view_up.begin());
  spec.view_angle = this->ViewAngle;
  spec.viewport = { static_cast<std::uint32_t>(this->ViewportSize[0]),
    static_cast<std::uint32_t>(this->ViewportSize[1]) };
  spec.pixel_tolerance = this->PixelTolerance;
  spec.max_tetrahedra = static_cast<std::size_t>(this->MaximumNumberOfTetrahedra);
  std::optional<rust::Box<bridge::MeshPlan>> plan;
  bridge::ViewFrame frame;
  try
  {
    if (!view || !(*view)->belongs_to(hierarchy))
    {
      view.reset();
      view.emplace(bridge::new_view_mesh(hierarchy));
    }
    this->UpdateProgress(0.7);
    frame = (*view)->update_view(hierarchy, spec);
    plan.emplace((*view)->view_plan(hierarchy));
    const rust::String warning = hierarchy.budget_warning(spec.max_tetrahedra);
    const std::pair<vtkIdType, vtkIdType> warned{ this->NumberOfHierarchyBuilds,
      this->MaximumNumberOfTetrahedra };
    if (!warning.empty() && this->Internals->BudgetWarned != warned)
    {
      this->Internals->BudgetWarned = warned;
      vtkWarningMacro(<< "View Dependent Tetrahedra, array \"" << array->GetName()
                      << "\": " << std::string(warning));
    }
    // With SortCells, the core writes the tetrahedra in that order (no tree, no reordering).
    hierarchy.order_plan(**plan, static_cast<std::uint8_t>(this->SortCells),
      rust::Slice<const double>(this->CameraPosition, 3));
  }
  catch (const rust::Error& e)
  {
    vtkErrorMacro(<< "View Dependent Tetrahedra refinement failed: " << e.what());
    return 0;
  }
  this->UpdateProgress(0.8);

  // ---- Output, written by the core (in the order asked), then each cell's bisection path.
  double maxError = 0.0;
  std::string error;
  if (!vtkDiamonds::PlanToUnstructuredGrid(hierarchy, **plan, input, output, maxError, error))
  {
    output->Initialize();
    vtkErrorMacro(<< "View Dependent Tetrahedra could not write its output: " << error);
    return 0;
  }
  const vtkIdType numTets = output->GetNumberOfCells();
  vtkNew<vtkTypeUInt64Array> paths;
  paths->SetName("BisectionPath");
  vtkDiamonds::Allocate(paths, numTets);
  try
  {
    (*plan)->write_paths(rust::Slice<std::uint64_t>(
      reinterpret_cast<std::uint64_t*>(paths->GetPointer(0)), static_cast<std::size_t>(numTets)));
  }
  catch (const rust::Error& e)
  {
    output->Initialize();
    vtkErrorMacro(<< "View Dependent Tetrahedra could not write the bisection paths: " << e.what());
    return 0;
  }
  plan.reset();
  vtkCellData* cd = output->GetCellData();
  vtkUnsignedCharArray* depths =
    vtkUnsignedCharArray::SafeDownCast(cd->GetAbstractArray("BisectionDepth"));
  vtkNew<vtkUnsignedCharArray> levels;
  levels->SetName("Level");
  vtkDiamonds::Allocate(levels, numTets);
  for (vtkIdType i = 0; i < numTets; ++i)
  {
    levels->SetValue(i, static_cast<unsigned char>(depths->GetValue(i) / 3));
  }
  cd->AddArray(levels);
  cd->AddArray(paths);
  if (this->SortCells != 0)
  {
    vtkDiamondsVisibilitySort::MarkOrdered(
      output, this->CameraPosition, this->SortCells == 2 ? vtkVisibilitySort::FRONT_TO_BACK
                                                         : vtkVisibilitySort::BACK_TO_FRONT);
  }
  this->UpdateProgress(0.95);

  const bridge::GridSpec grid = hierarchy.grid_spec();
  double gridValues[9];
  for (int a = 0; a < 3; ++a)
  {
    gridValues[a] = static_cast<double>(grid.dims[a]);
    gridValues[3 + a] = grid.origin[a];
    gridValues[6 + a] = grid.spacing[a];
  }
  vtkFieldData* fieldData = output->GetFieldData();
  fieldData->PassData(input->GetFieldData());
  fieldData->AddArray(vtkDiamonds::NamedArray<vtkDoubleArray>("BisectionGrid", 9, gridValues));
  fieldData->AddArray(OneValue<vtkDoubleArray>("PixelToleranceReached", frame.tolerance));
  fieldData->AddArray(OneValue<vtkIdTypeArray>("NumberOfTetrahedra", numTets));
  fieldData->AddArray(OneValue<vtkDoubleArray>("MaximumError", maxError));
  fieldData->AddArray(
    OneValue<vtkIdTypeArray>("FrameSplits", static_cast<vtkIdType>(frame.splits)));
  fieldData->AddArray(
    OneValue<vtkIdTypeArray>("FrameMerges", static_cast<vtkIdType>(frame.merges)));
  fieldData->AddArray(OneValue<vtkDoubleArray>("FrameSeconds", frame.seconds));
  this->UpdateProgress(1.0);
  return 1;
}
catch (const std::bad_alloc& e)
{
  vtkDiamonds::ReportOutOfMemory(this, "View Dependent Tetrahedra", outputVector, e);
  return 0;
}

//------------------------------------------------------------------------------
void vtkViewDependentTetrahedra::PrintSelf(ostream& os, vtkIndent indent)
{
  this->Superclass::PrintSelf(os, indent);
  os << indent << "CameraPosition: (" << this->CameraPosition[0] << ", " << this->CameraPosition[1]
     << ", " << this->CameraPosition[2] << ")\n";
  os << indent << "CameraFocalPoint: (" << this->CameraFocalPoint[0] << ", "
     << this->CameraFocalPoint[1] << ", " << this->CameraFocalPoint[2] << ")\n";
  os << indent << "CameraViewUp: (" << this->CameraViewUp[0] << ", " << this->CameraViewUp[1]
     << ", " << this->CameraViewUp[2] << ")\n";
  os << indent << "ViewAngle: " << this->ViewAngle << "\n";
  os << indent << "ViewportSize: " << this->ViewportSize[0] << " x " << this->ViewportSize[1]
     << "\n";
  os << indent << "PixelTolerance: " << this->PixelTolerance << "\n";
  os << indent << "MaximumNumberOfTetrahedra: " << this->MaximumNumberOfTetrahedra << "\n";
  os << indent << "SortCells: " << this->SortCells << "\n";
  os << indent << "NumberOfHierarchyBuilds: " << this->NumberOfHierarchyBuilds << "\n";
  os << indent << "MeshLocalPiece: " << this->MeshLocalPiece << "\n";
}
