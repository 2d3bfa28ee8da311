#include "vtkAdaptiveTetrahedra.h"

#include "vtkCellArray.h"
#include "vtkCellData.h"
#include "vtkDataArray.h"
#include "vtkDoubleArray.h"
#include "vtkFieldData.h"
#include "vtkFloatArray.h"
#include "vtkIdList.h"
#include "vtkIdTypeArray.h"
#include "vtkImageData.h"
#include "vtkInformation.h"
#include "vtkInformationVector.h"
#include "vtkMatrix3x3.h"
#include "vtkObjectFactory.h"
#include "vtkPointData.h"
#include "vtkPoints.h"
#include "vtkSmartPointer.h"
#include "vtkStreamingDemandDrivenPipeline.h"
#include "vtkTypeInt32Array.h"
#include "vtkTypeInt64Array.h"
#include "vtkUnsignedCharArray.h"
#include "vtkUnstructuredGrid.h"

// The cxx bridge. Kept out of the public header: the VTK wrappers parse that one.
#include "diamonds-bridge/src/lib.rs.h"
#include "rust/cxx.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <optional>
#include <sstream>
#include <string>

vtkStandardNewMacro(vtkAdaptiveTetrahedra);

namespace
{
namespace bridge = diamonds::bridge;

// Forwards the core's build progress to UpdateProgress, mapped onto [From, To], and turns an
// abort request into `false` (which makes the core stop and return an error).
class ProgressForwarder final : public bridge::ProgressObserver
{
public:
  ProgressForwarder(vtkAlgorithm* filter, double from, double to)
    : Filter(filter)
    , From(from)
    , To(to)
  {
  }

  bool report(double fraction) noexcept override
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

  bool Aborted = false;

private:
  vtkAlgorithm* Filter;
  double From;
  double To;
};

// What the cached hierarchy was built from. The array pointer is an identity only (never
// dereferenced); together with the array's MTime it detects a new or modified array.
struct HierarchyKey
{
  const void* Array = nullptr;
  vtkMTimeType ArrayMTime = 0;
  std::string Name;
  int DataType = 0;
  std::array<int, 6> Extent{};
  std::array<double, 3> Origin{};
  std::array<double, 3> Spacing{};

  bool operator==(const HierarchyKey& o) const
  {
    return this->Array == o.Array && this->ArrayMTime == o.ArrayMTime && this->Name == o.Name &&
      this->DataType == o.DataType && this->Extent == o.Extent && this->Origin == o.Origin &&
      this->Spacing == o.Spacing;
  }
};

// The sample type the core reads for a VTK array type, if it reads it in place.
std::optional<bridge::ScalarType> InPlaceType(vtkDataArray* array)
{
  switch (array->GetDataType())
  {
    case VTK_FLOAT:
      return bridge::ScalarType::F32;
    case VTK_DOUBLE:
      return bridge::ScalarType::F64;
    case VTK_CHAR:
    case VTK_SIGNED_CHAR:
    case VTK_UNSIGNED_CHAR:
    case VTK_SHORT:
    case VTK_UNSIGNED_SHORT:
    case VTK_INT:
    case VTK_UNSIGNED_INT:
    case VTK_LONG:
    case VTK_UNSIGNED_LONG:
    {
      const bool isSigned = array->GetDataTypeMin() < 0;
      switch (array->GetDataTypeSize())
      {
        case 1:
          return isSigned ? bridge::ScalarType::I8 : bridge::ScalarType::U8;
        case 2:
          return isSigned ? bridge::ScalarType::I16 : bridge::ScalarType::U16;
        case 4:
          return isSigned ? bridge::ScalarType::I32 : bridge::ScalarType::U32;
        default:
          return std::nullopt;
      }
    }
    default:
      return std::nullopt;
  }
}

bool Is64BitInteger(vtkDataArray* array)
{
  switch (array->GetDataType())
  {
    case VTK_LONG:
    case VTK_UNSIGNED_LONG:
    case VTK_LONG_LONG:
    case VTK_UNSIGNED_LONG_LONG:
    case VTK_ID_TYPE:
      return array->GetDataTypeSize() == 8;
    default:
      return false;
  }
}

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

template <typename ArrayT>
vtkSmartPointer<ArrayT> NamedArray(const char* name, vtkIdType n, const void* values)
{
  auto array = vtkSmartPointer<ArrayT>::New();
  array->SetName(name);
  array->SetNumberOfValues(n);
  if (n > 0)
  {
    std::memcpy(array->GetPointer(0), values, n * sizeof(typename ArrayT::ValueType));
  }
  return array;
}

template <typename ArrayT>
vtkSmartPointer<ArrayT> OneValue(const char* name, typename ArrayT::ValueType value)
{
  return NamedArray<ArrayT>(name, 1, &value);
}
} // namespace

class vtkAdaptiveTetrahedra::vtkInternals
{
public:
  std::optional<rust::Box<bridge::Hierarchy>> Hierarchy;
  HierarchyKey Key;
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
  // Each piece is meshed over its own extent: a ghost layer would be meshed as ordinary samples
  // and duplicate the neighbouring piece's tetrahedra. (Pieces of an image share their boundary
  // plane of points, so nothing is lost.)
  vtkInformation* inInfo = inputVector[0]->GetInformationObject(0);
  inInfo->Set(vtkStreamingDemandDrivenPipeline::UPDATE_NUMBER_OF_GHOST_LEVELS(), 0);
  return 1;
}

//------------------------------------------------------------------------------
vtkIdType vtkAdaptiveTetrahedra::GetHierarchyMemorySize()
{
  if (!this->Internals->Hierarchy)
  {
    return 0;
  }
  try
  {
    return static_cast<vtkIdType>((*this->Internals->Hierarchy)->metadata_bytes());
  }
  catch (const rust::Error& e)
  {
    vtkErrorMacro(<< e.what());
    return 0;
  }
}

//------------------------------------------------------------------------------
void vtkAdaptiveTetrahedra::ReleaseHierarchy()
{
  this->Internals->Hierarchy.reset();
  this->Internals->Key = HierarchyKey{};
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
  if (!input->GetDirectionMatrix()->IsIdentity())
  {
    vtkErrorMacro(<< "The input image is oriented (its direction matrix is not the identity); "
                     "Adaptive Tetrahedra supports axis-aligned images only. "
                     "Apply Resample To Image first.");
    return 0;
  }
  int extent[6];
  int dims[3];
  double origin[3];
  double spacing[3];
  input->GetExtent(extent);
  input->GetDimensions(dims);
  input->GetOrigin(origin);
  input->GetSpacing(spacing);

  // ---- The array to approximate.
  int association = vtkDataObject::FIELD_ASSOCIATION_POINTS;
  vtkDataArray* array = this->GetInputArrayToProcess(0, inputVector, association);
  if (!array)
  {
    vtkInformation* arrayInfo = this->GetInputArrayInformation(0);
    const char* requested =
      arrayInfo->Has(vtkDataObject::FIELD_NAME()) ? arrayInfo->Get(vtkDataObject::FIELD_NAME()) : nullptr;
    if (requested && *requested)
    {
      vtkErrorMacro(<< "The input has no point-data array named \"" << requested
                    << "\". Point arrays: " << ArrayNames(input->GetPointData()) << ".");
      return 0;
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
      vtkErrorMacro(<< "The input has no point scalars, only cell data ("
                    << ArrayNames(input->GetCellData())
                    << "). Adaptive Tetrahedra approximates a point-data array: "
                       "apply Cell Data to Point Data first.");
    }
    else
    {
      vtkErrorMacro(<< "The input has no point scalars: select a point-data array (Scalars).");
    }
    return 0;
  }
  const std::string name = array->GetName() ? array->GetName() : "";
  if (association != vtkDataObject::FIELD_ASSOCIATION_POINTS)
  {
    vtkErrorMacro(<< "Array \"" << name
                  << "\" is not point data. Adaptive Tetrahedra approximates a point-data "
                     "array: apply Cell Data to Point Data first.");
    return 0;
  }
  if (array->GetNumberOfComponents() != 1)
  {
    vtkErrorMacro(<< "Array \"" << name << "\" has " << array->GetNumberOfComponents()
                  << " components; Adaptive Tetrahedra needs a single-component array. "
                     "Use Calculator to extract a component (e.g. "
                  << name << "_X) or the magnitude (mag(" << name << ")).");
    return 0;
  }

  HierarchyKey key;
  key.Array = array;
  key.ArrayMTime = array->GetMTime();
  key.Name = name;
  key.DataType = array->GetDataType();
  std::copy(extent, extent + 6, key.Extent.begin());
  std::copy(origin, origin + 3, key.Origin.begin());
  std::copy(spacing, spacing + 3, key.Spacing.begin());

  // ---- Hierarchy: built only when the array or the geometry changed.
  vtkInternals& internals = *this->Internals;
  if (!internals.Hierarchy || !(internals.Key == key))
  {
    this->ReleaseHierarchy();

    vtkSmartPointer<vtkDataArray> samples = array;
    std::optional<bridge::ScalarType> type = InPlaceType(array);
    if (!type && Is64BitInteger(array))
    {
      double range[2];
      array->GetRange(range, 0);
      const double exact = 9007199254740992.0; // 2^53
      if (std::abs(range[0]) > exact || std::abs(range[1]) > exact)
      {
        vtkErrorMacro(<< "Array \"" << name << "\" holds 64-bit integers up to " << range[1]
                      << ", beyond 2^53 where a conversion to double is inexact. "
                         "Rescale it (e.g. with Calculator) first.");
        return 0;
      }
      vtkWarningMacro(<< "Array \"" << name << "\" holds 64-bit integers ("
                      << array->GetDataTypeAsString()
                      << "); they are converted to double for the approximation (exact, all "
                         "values are below 2^53). The passed-through array keeps its type.");
      samples = vtkSmartPointer<vtkDoubleArray>::New();
      samples->DeepCopy(array);
      type = bridge::ScalarType::F64;
    }
    if (!type)
    {
      vtkErrorMacro(<< "Array \"" << name << "\" has type " << array->GetDataTypeAsString()
                    << ", which Adaptive Tetrahedra does not read. Supported: 8-, 16-, 32- and "
                       "64-bit integers, float, double.");
      return 0;
    }
    if (!samples->HasStandardMemoryLayout())
    {
      // e.g. a structure-of-arrays or implicit array: the core reads one contiguous buffer.
      vtkSmartPointer<vtkDataArray> contiguous =
        vtkSmartPointer<vtkDataArray>::Take(vtkDataArray::CreateDataArray(samples->GetDataType()));
      contiguous->DeepCopy(samples);
      samples = contiguous;
    }

    bridge::GridSpec grid;
    for (int axis = 0; axis < 3; ++axis)
    {
      grid.dims[axis] = static_cast<std::size_t>(std::max(dims[axis], 0));
      grid.origin[axis] = origin[axis] + extent[2 * axis] * spacing[axis];
      grid.spacing[axis] = spacing[axis];
    }
    const auto* bytes = static_cast<const std::uint8_t*>(samples->GetVoidPointer(0));
    const std::size_t byteCount =
      static_cast<std::size_t>(samples->GetNumberOfValues()) * samples->GetDataTypeSize();

    ProgressForwarder progress(this, 0.0, 0.8);
    this->UpdateProgress(0.0);
    try
    {
      internals.Hierarchy.emplace(bridge::build_hierarchy(
        grid, *type, rust::Slice<const std::uint8_t>(bytes, byteCount), progress));
    }
    catch (const rust::Error& e)
    {
      if (progress.Aborted)
      {
        vtkDebugMacro(<< "Hierarchy build aborted.");
        return 1;
      }
      vtkErrorMacro(<< "Adaptive Tetrahedra cannot approximate array \"" << name
                    << "\": " << e.what());
      return 0;
    }
    internals.Key = key;
    ++this->NumberOfHierarchyBuilds;
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
  query.use_region_of_interest = false;
  std::copy(this->RegionOfInterest, this->RegionOfInterest + 6, query.region_of_interest.begin());
  if (this->UseRegionOfInterest)
  {
    const double* roi = this->RegionOfInterest;
    for (int axis = 0; axis < 3; ++axis)
    {
      if (!std::isfinite(roi[2 * axis]) || !std::isfinite(roi[2 * axis + 1]) ||
        roi[2 * axis] > roi[2 * axis + 1])
      {
        vtkErrorMacro(<< "RegionOfInterest (" << roi[0] << ", " << roi[1] << ", " << roi[2]
                      << ", " << roi[3] << ", " << roi[4] << ", " << roi[5]
                      << ") must be finite with min <= max on every axis.");
        return 0;
      }
    }
    // The region is checked against the whole image, not this process's piece.
    int wholeExtent[6];
    std::copy(extent, extent + 6, wholeExtent);
    vtkInformation* inInfo = inputVector[0]->GetInformationObject(0);
    if (inInfo->Has(vtkStreamingDemandDrivenPipeline::WHOLE_EXTENT()))
    {
      inInfo->Get(vtkStreamingDemandDrivenPipeline::WHOLE_EXTENT(), wholeExtent);
    }
    double wholeBounds[6];
    double pieceBounds[6];
    ExtentBounds(wholeExtent, origin, spacing, wholeBounds);
    ExtentBounds(extent, origin, spacing, pieceBounds);
    if (!BoxesTouch(roi, wholeBounds))
    {
      vtkErrorMacro(<< "RegionOfInterest (" << roi[0] << ", " << roi[1] << ", " << roi[2] << ", "
                    << roi[3] << ", " << roi[4] << ", " << roi[5]
                    << ") lies outside the image bounds (" << wholeBounds[0] << ", "
                    << wholeBounds[1] << ", " << wholeBounds[2] << ", " << wholeBounds[3] << ", "
                    << wholeBounds[4] << ", " << wholeBounds[5] << ").");
      return 0;
    }
    if (BoxesTouch(roi, pieceBounds))
    {
      query.use_region_of_interest = true;
    }
    else
    {
      // The region misses this piece: no diamond here is of interest, i.e. the coarsest mesh.
      query.tolerance = std::numeric_limits<double>::max();
    }
  }

  std::optional<rust::Box<bridge::Mesh>> mesh;
  try
  {
    mesh.emplace((*internals.Hierarchy)->query(query));
  }
  catch (const rust::Error& e)
  {
    vtkErrorMacro(<< "Adaptive Tetrahedra query failed: " << e.what());
    return 0;
  }
  this->UpdateProgress(0.9);

  // ---- Output.
  rust::Slice<const std::size_t> pointIds;
  rust::Slice<const std::uint32_t> tets;
  rust::Slice<const std::uint8_t> levels;
  rust::Slice<const float> errors;
  double maxError = 0.0;
  try
  {
    pointIds = (*mesh)->point_ids();
    tets = (*mesh)->tets();
    levels = (*mesh)->levels();
    errors = (*mesh)->errors();
    maxError = (*mesh)->max_error();
  }
  catch (const rust::Error& e)
  {
    vtkErrorMacro(<< e.what());
    return 0;
  }
  const vtkIdType numPoints = static_cast<vtkIdType>(pointIds.size());
  const vtkIdType numTets = static_cast<vtkIdType>(tets.size() / 4);

  // Points at the exact input sample positions (the formula vtkImageData uses for its bounds),
  // and the input ids to copy point data from.
  vtkNew<vtkPoints> points;
  points->SetDataTypeToDouble();
  points->SetNumberOfPoints(numPoints);
  double* xyz = vtkDoubleArray::SafeDownCast(points->GetData())->GetPointer(0);
  vtkNew<vtkIdList> inputIds;
  inputIds->SetNumberOfIds(numPoints);
  const std::size_t nx = static_cast<std::size_t>(dims[0]);
  const std::size_t nxy = nx * static_cast<std::size_t>(dims[1]);
  for (vtkIdType i = 0; i < numPoints; ++i)
  {
    const std::size_t id = pointIds[i];
    const std::size_t ijk[3] = { id % nx, (id % nxy) / nx, id / nxy };
    for (int axis = 0; axis < 3; ++axis)
    {
      xyz[3 * i + axis] =
        origin[axis] + (extent[2 * axis] + static_cast<double>(ijk[axis])) * spacing[axis];
    }
    inputIds->SetId(i, static_cast<vtkIdType>(id));
  }
  output->SetPoints(points);

  // Every input point-data array, tuple by tuple from the matching input point.
  vtkPointData* inPD = input->GetPointData();
  vtkPointData* outPD = output->GetPointData();
  outPD->CopyAllocate(inPD, numPoints);
  outPD->CopyData(inPD, inputIds, vtkIdType(0));

  // Cells: 32-bit connectivity when the point count allows (half the memory), else 64-bit.
  vtkNew<vtkCellArray> cells;
  if (numPoints <= std::numeric_limits<vtkTypeInt32>::max())
  {
    cells->SetData(4, NamedArray<vtkTypeInt32Array>(nullptr, 4 * numTets, tets.data()));
  }
  else
  {
    vtkNew<vtkTypeInt64Array> connectivity;
    connectivity->SetNumberOfValues(4 * numTets);
    std::copy(tets.begin(), tets.end(), connectivity->GetPointer(0));
    cells->SetData(4, connectivity);
  }
  output->SetCells(VTK_TETRA, cells);

  output->GetCellData()->AddArray(NamedArray<vtkUnsignedCharArray>("Level", numTets, levels.data()));
  output->GetCellData()->AddArray(
    NamedArray<vtkFloatArray>("ApproximationError", numTets, errors.data()));

  vtkFieldData* fieldData = output->GetFieldData();
  fieldData->PassData(input->GetFieldData());
  fieldData->AddArray(OneValue<vtkDoubleArray>("Tolerance", this->Tolerance));
  fieldData->AddArray(OneValue<vtkIdTypeArray>("NumberOfTetrahedra", numTets));
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
