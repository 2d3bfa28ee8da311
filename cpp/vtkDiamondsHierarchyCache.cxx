#include "vtkDiamondsHierarchyCache.h"

#include "vtkAlgorithm.h"
#include "vtkCellArray.h"
#include "vtkCellData.h"
#include "vtkDataArray.h"
#include "vtkDataObject.h"
#include "vtkDataSet.h"
#include "vtkDoubleArray.h"
#include "vtkFieldData.h"
#include "vtkFloatArray.h"
#include "vtkIdList.h"
#include "vtkImageData.h"
#include "vtkInformation.h"
#include "vtkInformationVector.h"
#include "vtkMatrix3x3.h"
#include "vtkPointData.h"
#include "vtkPoints.h"
#include "vtkStreamingDemandDrivenPipeline.h"
#include "vtkStringArray.h"
#include "vtkTypeUInt32Array.h"
#include "vtkIdTypeArray.h"
#include "vtkIntArray.h"
#include "vtkTypeInt32Array.h"
#include "vtkTypeInt64Array.h"
#include "vtkUnsignedCharArray.h"
#include "vtkUnstructuredGrid.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>
#include <utility>

namespace vtkDiamonds
{
namespace
{
// The geometry of an image (or image piece) as VTK reports it.
struct ImageGeometry
{
  int Extent[6];
  int Dims[3];
  double Origin[3];
  double Spacing[3];

  explicit ImageGeometry(vtkImageData* input)
  {
    input->GetExtent(this->Extent);
    input->GetDimensions(this->Dims);
    input->GetOrigin(this->Origin);
    input->GetSpacing(this->Spacing);
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

//------------------------------------------------------------------------------
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

//------------------------------------------------------------------------------
bool CheckAxisAligned(vtkAlgorithm* filter, const FilterText& text, vtkImageData* input)
{
  if (!input->GetDirectionMatrix()->IsIdentity())
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

//------------------------------------------------------------------------------
vtkSmartPointer<vtkCellArray> FixedSizeCells(
  int size, rust::Slice<const std::uint32_t> ids, vtkIdType numPoints)
{
  auto cells = vtkSmartPointer<vtkCellArray>::New();
  const auto n = static_cast<vtkIdType>(ids.size());
  if (numPoints <= std::numeric_limits<vtkTypeInt32>::max())
  {
    cells->SetData(size, NamedArray<vtkTypeInt32Array>(nullptr, n, ids.data()));
  }
  else
  {
    vtkNew<vtkTypeInt64Array> connectivity;
    connectivity->SetNumberOfValues(n);
    std::copy(ids.begin(), ids.end(), connectivity->GetPointer(0));
    cells->SetData(size, connectivity);
  }
  return cells;
}

//------------------------------------------------------------------------------
vtkSmartPointer<vtkPoints> PointsFrom(rust::Slice<const double> xyz)
{
  vtkNew<vtkDoubleArray> data;
  data->SetNumberOfComponents(3);
  data->SetNumberOfTuples(static_cast<vtkIdType>(xyz.size() / 3));
  std::copy(xyz.begin(), xyz.end(), data->GetPointer(0));
  auto points = vtkSmartPointer<vtkPoints>::New();
  points->SetData(data);
  return points;
}

vtkSmartPointer<vtkCellArray> CellsFrom(
  rust::Slice<const std::uint32_t> offsets, rust::Slice<const std::uint32_t> connectivity)
{
  auto cells = vtkSmartPointer<vtkCellArray>::New();
  if (offsets.size() < 2)
  {
    return cells;
  }
  vtkNew<vtkTypeInt64Array> off;
  off->SetNumberOfValues(static_cast<vtkIdType>(offsets.size()));
  std::copy(offsets.begin(), offsets.end(), off->GetPointer(0));
  vtkNew<vtkTypeInt64Array> conn;
  conn->SetNumberOfValues(static_cast<vtkIdType>(connectivity.size()));
  std::copy(connectivity.begin(), connectivity.end(), conn->GetPointer(0));
  cells->SetData(off, conn);
  return cells;
}

vtkSmartPointer<vtkStringArray> Strings(const char* name, const std::vector<std::string>& values)
{
  auto a = vtkSmartPointer<vtkStringArray>::New();
  a->SetName(name);
  a->SetNumberOfValues(static_cast<vtkIdType>(values.size()));
  for (std::size_t i = 0; i < values.size(); ++i)
  {
    a->SetValue(static_cast<vtkIdType>(i), values[i]);
  }
  return a;
}

namespace
{
// An empty array of the VTK class the core's type is written with.
vtkSmartPointer<vtkDataArray> NewArray(bridge::ArrayType type)
{
  static_assert(sizeof(vtkIdType) == 8, "64-bit output arrays are written as vtkIdType");
  switch (type)
  {
    case bridge::ArrayType::U8:
      return vtkSmartPointer<vtkUnsignedCharArray>::New();
    case bridge::ArrayType::I32:
      return vtkSmartPointer<vtkIntArray>::New();
    case bridge::ArrayType::U32:
      return vtkSmartPointer<vtkTypeUInt32Array>::New();
    case bridge::ArrayType::I64:
      return vtkSmartPointer<vtkIdTypeArray>::New();
    case bridge::ArrayType::F32:
      return vtkSmartPointer<vtkFloatArray>::New();
    default:
      return vtkSmartPointer<vtkDoubleArray>::New();
  }
}
} // namespace

void AddOutputArrays(const bridge::OutputArrays& arrays, vtkDataSet* output)
{
  for (std::size_t i = 0; i < arrays.len(); ++i)
  {
    const bridge::OutputArrayInfo info = arrays.info(i);
    const rust::Slice<const std::uint8_t> bytes = arrays.bytes(i);
    vtkSmartPointer<vtkDataArray> array = NewArray(info.value_type);
    const std::string name(info.name);
    array->SetName(name.c_str());
    array->SetNumberOfComponents(static_cast<int>(info.components));
    array->SetNumberOfTuples(
      static_cast<vtkIdType>(bytes.size() / (array->GetDataTypeSize() * info.components)));
    if (!bytes.empty())
    {
      std::memcpy(array->GetVoidPointer(0), bytes.data(), bytes.size());
    }
    vtkDataSetAttributes* attributes = nullptr;
    switch (info.association)
    {
      case bridge::ArrayAssociation::Point:
        attributes = output->GetPointData();
        break;
      case bridge::ArrayAssociation::Cell:
        attributes = output->GetCellData();
        break;
      default:
        output->GetFieldData()->AddArray(array);
        continue;
    }
    attributes->AddArray(array);
    if (info.active_scalars)
    {
      attributes->SetActiveScalars(name.c_str());
    }
  }
}

//------------------------------------------------------------------------------
void MeshToUnstructuredGrid(
  bridge::Mesh& mesh, vtkImageData* input, const char* errorName, vtkUnstructuredGrid* output)
{
  const rust::Slice<const std::size_t> pointIds = mesh.point_ids();
  const rust::Slice<const std::uint32_t> tets = mesh.tets();
  const rust::Slice<const std::uint8_t> levels = mesh.levels();
  const rust::Slice<const float> errors = mesh.errors();
  const vtkIdType numPoints = static_cast<vtkIdType>(pointIds.size());
  const vtkIdType numTets = static_cast<vtkIdType>(tets.size() / 4);

  const ImageGeometry image(input);
  const int* extent = image.Extent;
  const int* dims = image.Dims;
  const double* origin = image.Origin;
  const double* spacing = image.Spacing;

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

  vtkSmartPointer<vtkCellArray> cells = FixedSizeCells(4, tets, numPoints);
  // The connectivity is copied: free the core's copy before more arrays are allocated.
  mesh.release_tets();
  output->SetCells(VTK_TETRA, cells);

  output->GetCellData()->AddArray(
    NamedArray<vtkUnsignedCharArray>("Level", numTets, levels.data()));
  output->GetCellData()->AddArray(
    NamedArray<vtkFloatArray>(errorName, numTets, errors.data()));
}

//------------------------------------------------------------------------------
HierarchyCache::HierarchyCache(Use use)
  : Purpose(use)
{
}

bool HierarchyCache::Key::operator==(const Key& o) const
{
  return this->Array == o.Array && this->ArrayMTime == o.ArrayMTime && this->Name == o.Name &&
    this->DataType == o.DataType && this->Extent == o.Extent && this->Origin == o.Origin &&
    this->Spacing == o.Spacing;
}

rust::Slice<const std::uint8_t> HierarchyCache::GetSamples() const
{
  if (!this->Samples)
  {
    return {};
  }
  return rust::Slice<const std::uint8_t>(
    static_cast<const std::uint8_t*>(this->Samples->GetVoidPointer(0)),
    static_cast<std::size_t>(this->Samples->GetNumberOfValues()) *
      this->Samples->GetDataTypeSize());
}

vtkIdType HierarchyCache::GetMemorySize() const
{
  return this->Hierarchy ? static_cast<vtkIdType>((*this->Hierarchy)->metadata_bytes()) : 0;
}

void HierarchyCache::Release()
{
  this->IsoState.reset();
  this->Hierarchy.reset();
  this->Built = Key{};
  this->Samples = nullptr;
}

//------------------------------------------------------------------------------
HierarchyCache::Status HierarchyCache::Update(vtkAlgorithm* filter, const FilterText& text,
  vtkImageData* input, vtkDataArray* array, double from, double to)
{
  const ImageGeometry image(input);
  const int* extent = image.Extent;
  const int* dims = image.Dims;
  const double* origin = image.Origin;
  const double* spacing = image.Spacing;
  const std::string name = array->GetName() ? array->GetName() : "";

  Key key;
  key.Array = array;
  key.ArrayMTime = array->GetMTime();
  key.Name = name;
  key.DataType = array->GetDataType();
  std::copy(extent, extent + 6, key.Extent.begin());
  std::copy(origin, origin + 3, key.Origin.begin());
  std::copy(spacing, spacing + 3, key.Spacing.begin());
  if (this->Hierarchy && this->Built == key)
  {
    return Status::Kept;
  }
  this->Release();

  vtkSmartPointer<vtkDataArray> samples = array;
  std::optional<bridge::ScalarType> type = InPlaceType(array);
  if (!type && Is64BitInteger(array))
  {
    double range[2];
    array->GetRange(range, 0);
    const double exact = 9007199254740992.0; // 2^53
    if (std::abs(range[0]) > exact || std::abs(range[1]) > exact)
    {
      vtkErrorWithObjectMacro(filter,
        << "Array \"" << name << "\" holds 64-bit integers up to " << range[1]
        << ", beyond 2^53 where a conversion to double is inexact. "
           "Rescale it (e.g. with Calculator) first.");
      return Status::Failed;
    }
    vtkWarningWithObjectMacro(filter,
      << "Array \"" << name << "\" holds 64-bit integers (" << array->GetDataTypeAsString()
      << "); they are converted to double for " << text.Name
      << " (exact, all values are below 2^53). The input array keeps its type.");
    samples = vtkSmartPointer<vtkDoubleArray>::New();
    samples->DeepCopy(array);
    type = bridge::ScalarType::F64;
  }
  if (!type)
  {
    vtkErrorWithObjectMacro(filter,
      << "Array \"" << name << "\" has type " << array->GetDataTypeAsString() << ", which "
      << text.Name
      << " does not read. Supported: 8-, 16-, 32- and 64-bit integers, float, double.");
    return Status::Failed;
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

  ProgressForwarder progress(filter, from, to);
  filter->UpdateProgress(from);
  try
  {
    const rust::Slice<const std::uint8_t> slice(bytes, byteCount);
    rust::Box<bridge::Hierarchy> hierarchy = this->Purpose == Use::Isosurfaces
      ? bridge::build_isosurface_hierarchy(grid, *type, slice)
      : bridge::build_hierarchy(grid, *type, slice, progress);
    this->Hierarchy.emplace(std::move(hierarchy));
  }
  catch (const rust::Error& e)
  {
    if (progress.Aborted)
    {
      vtkDebugWithObjectMacro(filter, << "Hierarchy build aborted.");
      return Status::Aborted;
    }
    vtkErrorWithObjectMacro(filter,
      << text.Name << " cannot " << text.Verb << " array \"" << name << "\": " << e.what());
    return Status::Failed;
  }
  this->IsoState.emplace(bridge::new_iso_state());
  this->Built = key;
  this->SampleType = *type;
  if (this->Purpose == Use::Isosurfaces)
  {
    this->Samples = samples;
  }
  return Status::Built;
}
} // namespace vtkDiamonds
