// Internal to the Diamonds VTK module (not installed, not wrapped): the core's results as VTK data
// (points, cells, named arrays, tetrahedral meshes over the input image).
#ifndef vtkDiamondsOutput_h
#define vtkDiamondsOutput_h

#include "vtkDiamondsBridge.h"

#include "vtkSmartPointer.h"
#include "vtkType.h"

#include <cstdint>
#include <cstring>
#include <functional>
#include <new>
#include <string>
#include <vector>

class vtkAbstractArray;
class vtkAlgorithm;
class vtkCellArray;
class vtkDataSet;
class vtkDataArray;
class vtkDataSetAttributes;
class vtkIdTypeArray;
class vtkImageData;
class vtkInformationVector;
class vtkPointData;
class vtkPoints;
class vtkStringArray;
class vtkUnstructuredGrid;

namespace vtkDiamonds
{
// Thrown when an output array cannot be allocated; what() says which and how large. A std::bad_alloc,
// so one handler also catches VTK's own (vtkIdList, for instance, allocates with new[]).
class OutOfMemory : public std::bad_alloc
{
public:
  explicit OutOfMemory(std::string message)
    : Message(std::move(message))
  {
  }
  const char* what() const noexcept override { return this->Message.c_str(); }

private:
  std::string Message;
};

// Gives `array` (its number of components set) `values` values, contents undefined, or throws
// OutOfMemory. The filters' output arrays are allocated here rather than by VTK because VTK's data
// arrays abort the process when an allocation fails (ParaView 5.11's VTK is built without NDEBUG,
// so vtkGenericDataArray calls abort() after "Unable to allocate"): AOS arrays get their memory
// from malloc, others only after a malloc of their size succeeded.
void Allocate(vtkAbstractArray* array, vtkIdType values);

// Creates in `out` the arrays of `in` that CopyAllocate (or InterpolateAllocate, with
// `interpolate`) would, each with `tuples` tuples allocated by Allocate; throws OutOfMemory.
void AllocateLike(vtkDataSetAttributes* in, vtkDataSetAttributes* out, vtkIdType tuples,
  bool interpolate = false);

// Gives `out` every point array of `in` but the one named `skip` (none when null) and the ghost
// array, one tuple per point of a result whose points lie on edges between input points (the
// core's `sources` and `weights`, one pair and one weight per point): the input tuple at a sample
// (sources i, i), (1 - w) a[i] + w a[j] between samples i and j, as
// vtkDataSetAttributes::InterpolateEdge computes it (vtkContourFilter's point data). Throws
// OutOfMemory.
void InterpolatePointData(vtkPointData* in, const char* skip,
  rust::Slice<const std::uint32_t> sources, rust::Slice<const double> weights, vtkPointData* out);

// The message of an allocation failure caught as `e`: OutOfMemory's, or a generic one.
std::string OutOfMemoryMessage(const std::bad_alloc& e);

// What a filter's RequestData does when memory ran out (its body is a function-try-block catching
// std::bad_alloc): every output emptied (no partial result), the error reported on `filter`, named
// `name`.
void ReportOutOfMemory(
  vtkAlgorithm* filter, const char* name, vtkInformationVector* outputVector, const std::bad_alloc& e);
// The error of ReportOutOfMemory alone (for a distributed step, whose outputs are emptied when the
// ranks agree on the failure).
void ReportOutOfMemory(vtkAlgorithm* filter, const char* name, const std::bad_alloc& e);

// Fills `output` with the tetrahedra of `mesh` over `input`: points at the sample positions, every
// input point array passed through, cell data "BisectionDepth" and the mesh's per-tetrahedron errors named
// `errorName` ("ApproximationError" for Adaptive Tetrahedra, "IsosurfaceError" for carriers). The mesh's
// tetrahedra are released as soon as they are copied (lower peak memory). With a `table` (a piece's
// Pieces::SourceTable), the point data comes from the table's `rows`, one per point of the mesh,
// instead of from `input`. Throws OutOfMemory.
void MeshToUnstructuredGrid(bridge::Mesh& mesh, vtkImageData* input, const char* errorName,
  vtkUnstructuredGrid* output, vtkPointData* table = nullptr,
  rust::Slice<const std::uint32_t> rows = {});

// How a point array is gathered by the core: `gather(in, source, tupleBytes, target)` copies the
// tuple of each output point into `target` from `source`, the bytes of the input array `in`.
using PointGather = std::function<void(vtkDataArray* in, rust::Slice<const std::uint8_t> source,
  std::size_t tupleBytes, rust::Slice<std::uint8_t> target)>;

// Passes every point array of `in` into `out` (`numPoints` tuples) as CopyData would (the same
// arrays, attributes and information; arrays CopyAllocate leaves out, such as global ids, stay out):
// a numeric array by `gather` (the core copies each output point's tuple, in parallel); with
// `writeIds`, an array of other memory layout or type tuple by tuple from the input point ids it
// writes; without, a numeric array of other layout is gathered from a contiguous copy and an array
// of other type (strings) is left out. Throws OutOfMemory and what the callbacks throw (rust::Error);
// returns false with `error` set when the output arrays cannot be matched with the input's.
bool PassPointData(vtkPointData* in, vtkPointData* out, vtkIdType numPoints,
  const PointGather& gather, const std::function<void(rust::Slice<std::int64_t>)>& writeIds,
  std::string& error);

// `array` itself when its values are one contiguous block of tuples, else a copy that is (throws
// OutOfMemory).
vtkSmartPointer<vtkDataArray> Contiguous(vtkDataArray* array);

// How the tetrahedra of a mesh plan are written, with 32- or 64-bit ids (the core's
// write_tets_i32/_i64 of the hierarchy that planned it): connectivity, offsets, depths, errors;
// returns the largest error.
template <typename Id>
using TetWriter = std::function<double(
  rust::Slice<Id>, rust::Slice<Id>, rust::Slice<std::uint8_t>, rust::Slice<float>)>;

// Fills `output` with the tetrahedra of `plan` over `inPD`'s points, written by the core straight
// into the VTK arrays, each allocated here once with its exact size: connectivity and offsets
// (32-bit when the ids fit, by `tets32`, else by `tets64`), points at `frame`'s positions, every
// point array of `inPD` passed through (`gather`, `writeIds` as PassPointData), cell data
// "BisectionDepth" and "ApproximationError", and with `globalIds` the point ids in the whole grid as
// "GlobalPointIds". Returns false with `error` set (and `output` left incomplete: the caller
// initializes it again) when an array cannot be allocated or the core fails; else sets `maxError`
// to the largest error.
bool WritePlan(const bridge::MeshPlan& plan, const bridge::PointFrame& frame, vtkPointData* inPD,
  const PointGather& gather, const std::function<void(rust::Slice<std::int64_t>)>& writeIds,
  const TetWriter<std::int32_t>& tets32, const TetWriter<std::int64_t>& tets64, bool globalIds,
  vtkUnstructuredGrid* output, double& maxError, std::string& error);

// WritePlan for a plan of the serial `hierarchy` over `input`: points at its sample positions, its
// point arrays passed through.
bool PlanToUnstructuredGrid(const bridge::Hierarchy& hierarchy, const bridge::MeshPlan& plan,
  vtkImageData* input, vtkUnstructuredGrid* output, double& maxError, std::string& error);

// A named array of `n` values copied from `values` (throws OutOfMemory).
template <typename ArrayT>
vtkSmartPointer<ArrayT> NamedArray(const char* name, vtkIdType n, const void* values)
{
  auto array = vtkSmartPointer<ArrayT>::New();
  array->SetName(name);
  Allocate(array, n);
  if (n > 0)
  {
    std::memcpy(array->GetPointer(0), values, n * sizeof(typename ArrayT::ValueType));
  }
  return array;
}

// Cells of `size` points each from `ids` (point indices below `numPoints`, `size` per cell): 32-bit
// connectivity when the point count allows (half the memory), else 64-bit. Throws OutOfMemory, as
// the three functions below.
vtkSmartPointer<vtkCellArray> FixedSizeCells(
  int size, rust::Slice<const std::uint32_t> ids, vtkIdType numPoints);

// Points from three coordinates per point.
vtkSmartPointer<vtkPoints> PointsFrom(rust::Slice<const double> xyz);

// Polygons from core offsets (one per polygon plus one, or empty for none) and connectivity.
vtkSmartPointer<vtkCellArray> CellsFrom(
  rust::Slice<const std::uint32_t> offsets, rust::Slice<const std::uint32_t> connectivity);

// A named string array.
vtkSmartPointer<vtkStringArray> Strings(const char* name, const std::vector<std::string>& values);

// Sets the cells of `output`, all tetrahedra (the cell types array allocated by Allocate).
void SetTetrahedra(vtkUnstructuredGrid* output, vtkCellArray* cells);

// Adds the core's named arrays to the point, cell or field data of `output`, in order, and makes
// the arrays marked so the active scalars (throws OutOfMemory).
void AddOutputArrays(const bridge::OutputArrays& arrays, vtkDataSet* output);

// The point array "GlobalPointIds" of a rank's share of a distributed output: `ids`, each point's
// index in the whole output.
vtkSmartPointer<vtkIdTypeArray> GlobalPointIds(rust::Slice<const std::uint64_t> ids);

// A named one-value array (field data).
template <typename ArrayT>
vtkSmartPointer<ArrayT> OneValue(const char* name, typename ArrayT::ValueType value)
{
  return NamedArray<ArrayT>(name, 1, &value);
}
} // namespace vtkDiamonds

#endif
