#include "vtkDiamondsOutput.h"

#include "vtkDiamondsImageGeometry.h"

#include "vtkAlgorithm.h"
#include "vtkCellArray.h"
#include "vtkCellData.h"
#include "vtkDataSet.h"
#include "vtkDoubleArray.h"
#include "vtkFieldData.h"
#include "vtkFloatArray.h"
#include "vtkIdList.h"
#include "vtkIdTypeArray.h"
#include "vtkImageData.h"
#include "vtkInformationVector.h"
#include "vtkIntArray.h"
#include "vtkNew.h"
#include "vtkPointData.h"
#include "vtkPoints.h"
#include "vtkStringArray.h"
#include "vtkTypeInt32Array.h"
#include "vtkTypeInt64Array.h"
#include "vtkTypeUInt32Array.h"
#include "vtkUnsignedCharArray.h"
#include "vtkUnstructuredGrid.h"

#include <algorithm>
#include <cstdlib>
#include <cstring>
#include <limits>
#include <string>
#include <type_traits>

namespace vtkDiamonds
{
void Allocate(vtkAbstractArray* array, vtkIdType values)
{
  values = std::max<vtkIdType>(values, 0);
  const std::size_t bytes =
    static_cast<std::size_t>(values) * static_cast<std::size_t>(array->GetDataTypeSize());
  auto fail = [&]()
  {
    const char* name = array->GetName();
    return OutOfMemory("not enough memory for " + std::to_string(values) + " values of " +
      array->GetDataTypeAsString() + " (" + std::to_string(bytes >> 20) + " MiB)" +
      (name ? std::string(" for \"") + name + "\"" : std::string()));
  };
  void* memory = std::malloc(std::max<std::size_t>(bytes, 1));
  if (!memory)
  {
    throw fail();
  }
  if (array->GetArrayType() == vtkAbstractArray::AoSDataArrayTemplate)
  {
    array->SetVoidArray(memory, values, 0, vtkAbstractArray::VTK_DATA_ARRAY_FREE);
    return;
  }
  std::free(memory); // the memory is there: VTK's own allocation will not abort
  if (!array->SetNumberOfValues(values))
  {
    throw fail();
  }
}

void AllocateLike(vtkDataSetAttributes* in, vtkDataSetAttributes* out, vtkIdType tuples,
  bool interpolate)
{
  // One tuple each (VTK's allocation, which cannot fail at that size), then the real size.
  if (interpolate)
  {
    out->InterpolateAllocate(in, 1);
  }
  else
  {
    out->CopyAllocate(in, 1);
  }
  for (int k = 0; k < out->GetNumberOfArrays(); ++k)
  {
    vtkAbstractArray* array = out->GetAbstractArray(k);
    Allocate(array, tuples * array->GetNumberOfComponents());
  }
}

void InterpolatePointData(vtkPointData* in, const char* skip,
  rust::Slice<const std::uint32_t> sources, rust::Slice<const double> weights, vtkPointData* out)
{
  vtkNew<vtkPointData> source;
  source->ShallowCopy(in);
  if (skip)
  {
    source->RemoveArray(skip);
  }
  source->RemoveArray(vtkDataSetAttributes::GhostArrayName());
  if (source->GetNumberOfArrays() == 0)
  {
    return;
  }
  const vtkIdType numPoints = static_cast<vtkIdType>(weights.size());
  AllocateLike(source, out, numPoints, /*interpolate=*/true);
  for (vtkIdType i = 0; i < numPoints; ++i)
  {
    const vtkIdType a = sources[2 * i];
    const vtkIdType b = sources[2 * i + 1];
    if (a == b)
    {
      out->CopyData(source, a, i);
    }
    else
    {
      out->InterpolateEdge(source, i, a, b, weights[i]);
    }
  }
}

std::string OutOfMemoryMessage(const std::bad_alloc& e)
{
  return dynamic_cast<const OutOfMemory*>(&e) ? e.what() : "not enough memory";
}

void ReportOutOfMemory(
  vtkAlgorithm* filter, const char* name, vtkInformationVector* outputVector, const std::bad_alloc& e)
{
  for (int port = 0; port < outputVector->GetNumberOfInformationObjects(); ++port)
  {
    if (vtkDataObject* output = vtkDataObject::GetData(outputVector, port))
    {
      output->Initialize();
    }
  }
  ReportOutOfMemory(filter, name, e);
}

void ReportOutOfMemory(vtkAlgorithm* filter, const char* name, const std::bad_alloc& e)
{
  vtkErrorWithObjectMacro(filter,
    << name << " ran out of memory: " << OutOfMemoryMessage(e)
    << ". Its outputs are empty; raise the tolerance, set a maximum number of cells, restrict the "
       "input (e.g. Extract Subset) or free memory, and apply again.");
}

void SetTetrahedra(vtkUnstructuredGrid* output, vtkCellArray* cells)
{
  vtkNew<vtkUnsignedCharArray> types;
  Allocate(types, cells->GetNumberOfCells());
  types->FillValue(VTK_TETRA);
  output->SetCells(types, cells);
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
    Allocate(connectivity, n);
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
  Allocate(data, static_cast<vtkIdType>(xyz.size() / 3 * 3));
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
  Allocate(off, static_cast<vtkIdType>(offsets.size()));
  std::copy(offsets.begin(), offsets.end(), off->GetPointer(0));
  vtkNew<vtkTypeInt64Array> conn;
  Allocate(conn, static_cast<vtkIdType>(connectivity.size()));
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
    Allocate(array, static_cast<vtkIdType>(bytes.size() / array->GetDataTypeSize()));
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
namespace
{
// A new array of `tuples` tuples of `components` values (contents undefined); throws OutOfMemory.
template <typename ArrayT>
vtkSmartPointer<ArrayT> Uninitialized(const char* name, vtkIdType tuples, int components)
{
  auto array = vtkSmartPointer<ArrayT>::New();
  array->SetName(name);
  array->SetNumberOfComponents(components);
  Allocate(array, tuples * components);
  return array;
}

// Connectivity and offsets of `IdArrayT` (vtkTypeInt32Array or vtkTypeInt64Array) written by the
// core, with the depths and errors; the cells are set on `output` with their cell data.
template <typename IdArrayT, typename Write>
double WriteTetrahedra(vtkIdType numTets, vtkUnstructuredGrid* output, Write write)
{
  auto connectivity = Uninitialized<IdArrayT>(nullptr, 4 * numTets, 1);
  auto offsets = Uninitialized<IdArrayT>(nullptr, numTets + 1, 1);
  auto depths = Uninitialized<vtkUnsignedCharArray>("BisectionDepth", numTets, 1);
  auto errors = Uninitialized<vtkFloatArray>("ApproximationError", numTets, 1);
  // vtkTypeInt64 is long long, the bridge's i64 is std::int64_t (long): the same 64-bit integers.
  using Id = std::conditional_t<sizeof(typename IdArrayT::ValueType) == 4, std::int32_t,
    std::int64_t>;
  static_assert(sizeof(Id) == sizeof(typename IdArrayT::ValueType), "ids of the same width");
  const double maxError = write(
    rust::Slice<Id>(reinterpret_cast<Id*>(connectivity->GetPointer(0)), 4 * numTets),
    rust::Slice<Id>(reinterpret_cast<Id*>(offsets->GetPointer(0)), numTets + 1),
    rust::Slice<std::uint8_t>(depths->GetPointer(0), numTets),
    rust::Slice<float>(errors->GetPointer(0), numTets));
  vtkNew<vtkCellArray> cells;
  cells->SetData(offsets, connectivity);
  SetTetrahedra(output, cells);
  output->GetCellData()->AddArray(depths);
  output->GetCellData()->AddArray(errors);
  return maxError;
}

// Whether `a` and `b` are arrays of the same name (or both unnamed), type and components.
bool SameKind(vtkAbstractArray* a, vtkAbstractArray* b)
{
  const char* na = a->GetName();
  const char* nb = b->GetName();
  const bool sameName = (!na && !nb) || (na && nb && std::strcmp(na, nb) == 0);
  return sameName && a->GetDataType() == b->GetDataType() &&
    a->GetNumberOfComponents() == b->GetNumberOfComponents();
}
} // namespace

vtkSmartPointer<vtkDataArray> Contiguous(vtkDataArray* array)
{
  if (array->HasStandardMemoryLayout())
  {
    return array;
  }
  auto copy = vtkSmartPointer<vtkDataArray>::Take(vtkDataArray::CreateDataArray(array->GetDataType()));
  copy->SetNumberOfComponents(array->GetNumberOfComponents());
  Allocate(copy, array->GetNumberOfValues());
  copy->InsertTuples(0, array->GetNumberOfTuples(), 0, array);
  return copy;
}

bool PassPointData(vtkPointData* inPD, vtkPointData* outPD, vtkIdType numPoints,
  const PointGather& gather, const std::function<void(rust::Slice<std::int64_t>)>& writeIds,
  std::string& error)
{
  AllocateLike(inPD, outPD, numPoints);
  vtkNew<vtkIdList> pointIds; // only for arrays that are not one contiguous block
  for (int i = 0, k = 0; k < outPD->GetNumberOfArrays(); ++i)
  {
    vtkAbstractArray* in = inPD->GetAbstractArray(i);
    vtkAbstractArray* out = outPD->GetAbstractArray(k);
    if (!in)
    {
      error = "cannot match the output point arrays with the input's";
      return false;
    }
    if (!SameKind(in, out))
    {
      continue; // not passed through (e.g. global ids, as CopyData)
    }
    vtkDataArray* data = vtkDataArray::SafeDownCast(in);
    if (!data && !writeIds)
    {
      outPD->RemoveArray(k); // no tuple-by-tuple copy: left out
      continue;
    }
    ++k;
    if (numPoints == 0)
    {
      continue;
    }
    if (data && (data->HasStandardMemoryLayout() || !writeIds))
    {
      const vtkSmartPointer<vtkDataArray> contiguous = Contiguous(data);
      const std::size_t tupleBytes =
        static_cast<std::size_t>(data->GetDataTypeSize()) * data->GetNumberOfComponents();
      const auto* source = static_cast<const std::uint8_t*>(contiguous->GetVoidPointer(0));
      gather(data, rust::Slice<const std::uint8_t>(source, tupleBytes * data->GetNumberOfTuples()),
        tupleBytes,
        rust::Slice<std::uint8_t>(
          static_cast<std::uint8_t*>(out->GetVoidPointer(0)), tupleBytes * numPoints));
    }
    else
    {
      if (pointIds->GetNumberOfIds() != numPoints)
      {
        pointIds->SetNumberOfIds(numPoints);
        writeIds(rust::Slice<std::int64_t>(
          reinterpret_cast<std::int64_t*>(pointIds->GetPointer(0)), numPoints));
      }
      in->GetTuples(pointIds, out);
    }
  }
  return true;
}

bool WritePlan(const bridge::MeshPlan& plan, const bridge::PointFrame& frame, vtkPointData* inPD,
  const PointGather& gather, const std::function<void(rust::Slice<std::int64_t>)>& writeIds,
  const TetWriter<std::int32_t>& tets32, const TetWriter<std::int64_t>& tets64, bool globalIds,
  vtkUnstructuredGrid* output, double& maxError, std::string& error)
{
  const vtkIdType numPoints = static_cast<vtkIdType>(plan.number_of_points());
  const vtkIdType numTets = static_cast<vtkIdType>(plan.number_of_tetrahedra());
  try
  {
    auto xyz = Uninitialized<vtkDoubleArray>(nullptr, numPoints, 3);
    plan.write_points(frame, rust::Slice<double>(xyz->GetPointer(0), 3 * numPoints));
    vtkNew<vtkPoints> points;
    points->SetData(xyz);
    output->SetPoints(points);

    if (!PassPointData(inPD, output->GetPointData(), numPoints, gather, writeIds, error))
    {
      return false;
    }
    if (globalIds)
    {
      auto ids = Uninitialized<vtkIdTypeArray>("GlobalPointIds", numPoints, 1);
      plan.write_point_ids(
        rust::Slice<std::int64_t>(reinterpret_cast<std::int64_t*>(ids->GetPointer(0)), numPoints));
      output->GetPointData()->SetGlobalIds(ids);
    }

    // Tetrahedra with 32-bit ids when the points and the offsets allow (half the memory).
    if (numPoints <= std::numeric_limits<vtkTypeInt32>::max() &&
      4 * numTets <= std::numeric_limits<vtkTypeInt32>::max())
    {
      maxError = WriteTetrahedra<vtkTypeInt32Array>(numTets, output, tets32);
    }
    else
    {
      maxError = WriteTetrahedra<vtkTypeInt64Array>(numTets, output, tets64);
    }
    return true;
  }
  catch (const rust::Error& e)
  {
    error = e.what();
  }
  catch (const std::bad_alloc& e)
  {
    error = OutOfMemoryMessage(e);
  }
  return false;
}

bool PlanToUnstructuredGrid(const bridge::Hierarchy& hierarchy, const bridge::MeshPlan& plan,
  vtkImageData* input, vtkUnstructuredGrid* output, double& maxError, std::string& error)
{
  // Points at the exact input sample positions (the formula vtkImageData uses for its bounds).
  const ImageGeometry image(input);
  bridge::PointFrame frame;
  for (int axis = 0; axis < 3; ++axis)
  {
    frame.origin[axis] = image.Origin[axis];
    frame.first_index[axis] = image.Extent[2 * axis];
    frame.spacing[axis] = image.Spacing[axis];
  }
  return WritePlan(
    plan, frame, input->GetPointData(),
    [&](vtkDataArray*, rust::Slice<const std::uint8_t> source, std::size_t tupleBytes,
      rust::Slice<std::uint8_t> target) { plan.gather_point_values(source, tupleBytes, target); },
    [&](rust::Slice<std::int64_t> ids) { plan.write_point_ids(ids); },
    [&](rust::Slice<std::int32_t> c, rust::Slice<std::int32_t> o, rust::Slice<std::uint8_t> d,
      rust::Slice<float> e) { return hierarchy.write_tets_i32(plan, c, o, d, e); },
    [&](rust::Slice<std::int64_t> c, rust::Slice<std::int64_t> o, rust::Slice<std::uint8_t> d,
      rust::Slice<float> e) { return hierarchy.write_tets_i64(plan, c, o, d, e); },
    false, output, maxError, error);
}

//------------------------------------------------------------------------------
void MeshToUnstructuredGrid(bridge::Mesh& mesh, vtkImageData* input, const char* errorName,
  vtkUnstructuredGrid* output, vtkPointData* table, rust::Slice<const std::uint32_t> rows)
{
  const rust::Slice<const std::size_t> pointIds = mesh.point_ids();
  const rust::Slice<const std::uint32_t> tets = mesh.tets();
  const rust::Slice<const std::uint8_t> levels = mesh.depths();
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
  auto coordinates = Uninitialized<vtkDoubleArray>(nullptr, numPoints, 3);
  double* xyz = coordinates->GetPointer(0);
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
    inputIds->SetId(i, static_cast<vtkIdType>(table ? rows[i] : id));
  }
  vtkNew<vtkPoints> points;
  points->SetData(coordinates);
  output->SetPoints(points);

  // Every input point-data array, tuple by tuple from the matching input point (or table row).
  vtkPointData* inPD = table ? table : input->GetPointData();
  vtkPointData* outPD = output->GetPointData();
  AllocateLike(inPD, outPD, numPoints);
  outPD->CopyData(inPD, inputIds, vtkIdType(0));

  vtkSmartPointer<vtkCellArray> cells = FixedSizeCells(4, tets, numPoints);
  // The connectivity is copied: free the core's copy before more arrays are allocated.
  mesh.release_tets();
  SetTetrahedra(output, cells);

  output->GetCellData()->AddArray(
    NamedArray<vtkUnsignedCharArray>("BisectionDepth", numTets, levels.data()));
  output->GetCellData()->AddArray(
    NamedArray<vtkFloatArray>(errorName, numTets, errors.data()));
}

//------------------------------------------------------------------------------
vtkSmartPointer<vtkIdTypeArray> GlobalPointIds(rust::Slice<const std::uint64_t> ids)
{
  auto globalIds = vtkSmartPointer<vtkIdTypeArray>::New();
  globalIds->SetName("GlobalPointIds");
  globalIds->SetNumberOfValues(static_cast<vtkIdType>(ids.size()));
  std::copy(ids.begin(), ids.end(), globalIds->GetPointer(0));
  return globalIds;
}

} // namespace vtkDiamonds
