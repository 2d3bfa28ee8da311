#include "vtkProgressiveTetrahedralMesh.h"

#include "vtkAbstractArray.h"
#include "vtkCellArray.h"
#include "vtkCellData.h"
#include "vtkCommunicator.h"
#include "vtkContourValues.h"
#include "vtkDataSetTriangleFilter.h"
#include "vtkDoubleArray.h"
#include "vtkFieldData.h"
#include "vtkIdTypeArray.h"
#include "vtkInformation.h"
#include "vtkInformationVector.h"
#include "vtkMultiProcessController.h"
#include "vtkNew.h"
#include "vtkObjectFactory.h"
#include "vtkPointData.h"
#include "vtkPoints.h"
#include "vtkPolyData.h"
#include "vtkSmartPointer.h"
#include "vtkTypeInt32Array.h"
#include "vtkUnsignedCharArray.h"
#include "vtkUnstructuredGrid.h"

// The module's internal helpers and the cxx bridge. Kept out of the public header: the VTK
// wrappers parse that one.
#include "vtkDiamondsOutput.h"
#include "vtkDiamondsPieces.h"
#include "vtkDiamondsProgress.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <functional>
#include <limits>
#include <new>
#include <optional>
#include <string>
#include <vector>

vtkStandardNewMacro(vtkProgressiveTetrahedralMesh);

namespace
{
namespace bridge = diamonds::bridge;
using vtkDiamonds::OneValue;

// What the kept sequence was computed from: a change of any of these recomputes it.
struct Key
{
  vtkUnstructuredGrid* Input = nullptr;
  vtkMTimeType InputTime = 0;
  vtkDataArray* Array = nullptr;
  vtkMTimeType ArrayTime = 0;
  double Weights[3] = { 0, 0, 0 };
  bool Preserve = false;
  double Tolerance = 0;

  bool operator==(const Key& o) const
  {
    return Input == o.Input && InputTime == o.InputTime && Array == o.Array &&
      ArrayTime == o.ArrayTime && Weights[0] == o.Weights[0] && Weights[1] == o.Weights[1] &&
      Weights[2] == o.Weights[2] && Preserve == o.Preserve && Tolerance == o.Tolerance;
  }
};

// Under MPI, the collective steps every rank takes alike before any leaves. Whether some rank's
// checks failed (`ok` false: then every rank stops, and the message is for the others) and
// whether some rank must compute its sequence (`build`: then every rank with cells computes it
// again, since a changed piece may change its neighbours' seams, and `flatten` fills `points` and
// `corners` when they are empty). Then `bounds` become the whole mesh's, `boundary` this piece's
// boundary points and `seamWith` the boundary points of the other pieces near it: each rank sends
// each other rank its boundary points inside that rank's bounds (bridge::progressive_seam_messages;
// the core keeps this piece's points at those positions, so the pieces stay conforming), so a
// rank receives only from its neighbours, not every piece's boundary. Returns why every rank
// stops, or nothing.
std::string Distributed(vtkMultiProcessController* controller, bool ok, vtkIdType cells,
  bool& build, std::array<double, 6>& bounds, const std::function<void()>& flatten,
  const std::vector<double>& points, const std::vector<std::int64_t>& corners,
  rust::Vec<std::uint32_t>& boundary, std::vector<double>& seamWith)
{
  const int flags[2] = { ok ? 0 : 1, build ? 1 : 0 };
  int any[2] = { 0, 0 };
  controller->AllReduce(flags, any, 2, vtkCommunicator::MAX_OP);
  vtkIdType total = 0;
  controller->AllReduce(&cells, &total, 1, vtkCommunicator::SUM_OP);
  if (any[0])
  {
    return "stopped because the piece of another rank failed (that rank reported why).";
  }
  if (total == 0)
  {
    return "the input has no cells on any rank.";
  }
  if (!any[1])
  {
    return {};
  }
  // A failure of this rank from here on (out of memory for its copies or its messages) is agreed
  // on after the exchange, in which it still takes part (sending nothing).
  std::string failed;
  build = cells > 0;
  if (build && points.empty())
  {
    try
    {
      flatten();
    }
    catch (const std::bad_alloc& e)
    {
      failed = "out of memory for this piece's points and tetrahedra: " +
        vtkDiamonds::OutOfMemoryMessage(e) + ".";
    }
  }
  // Every piece's bounds (an empty piece's minima above its maxima), and the whole mesh's.
  vtkDiamonds::Ranks ranks(controller);
  std::array<double, 6> mine = bounds;
  if (cells == 0)
  {
    for (int a = 0; a < 3; ++a)
    {
      mine[2 * a] = std::numeric_limits<double>::infinity();
      mine[2 * a + 1] = -std::numeric_limits<double>::infinity();
    }
  }
  std::vector<double> boxes(6 * static_cast<std::size_t>(ranks.Size()));
  controller->AllGather(mine.data(), boxes.data(), 6);
  for (int a = 0; a < 3; ++a)
  {
    bounds[2 * a] = std::numeric_limits<double>::infinity();
    bounds[2 * a + 1] = -std::numeric_limits<double>::infinity();
    for (int r = 0; r < ranks.Size(); ++r)
    {
      bounds[2 * a] = std::min(bounds[2 * a], boxes[6 * r + 2 * a]);
      bounds[2 * a + 1] = std::max(bounds[2 * a + 1], boxes[6 * r + 2 * a + 1]);
    }
  }
  std::optional<bridge::SeamMessages> messages;
  if (build && failed.empty())
  {
    try
    {
      messages.emplace(bridge::progressive_seam_messages(
        rust::Slice<const double>(points.data(), points.size()),
        rust::Slice<const std::int64_t>(corners.data(), corners.size()),
        rust::Slice<const double>(boxes.data(), boxes.size()),
        static_cast<std::size_t>(ranks.Rank())));
    }
    catch (const rust::Error& e)
    {
      // Out of memory stops every rank: the neighbours would not keep this piece's seam points.
      // Bad tetrahedra: the build reports it; this rank sends nothing but takes part.
      if (bridge::ran_out_of_memory())
      {
        failed = std::string("the boundary points this piece sends its neighbours: ") + e.what();
      }
    }
  }
  const std::vector<std::size_t> none(static_cast<std::size_t>(ranks.Size()), 0);
  const rust::Slice<const std::size_t> counts = messages
    ? rust::Slice<const std::size_t>(messages->counts.data(), messages->counts.size())
    : rust::Slice<const std::size_t>(none.data(), none.size());
  const double* coordinates = messages ? messages->coordinates.data() : nullptr;
  std::string error;
  bool moved = false;
  const bool exchanged = ranks.Exchange(counts, coordinates, seamWith, moved, error);
  if (!ranks.AllOk(exchanged && failed.empty()))
  {
    if (!failed.empty())
    {
      return failed;
    }
    return exchanged ? "another rank ran out of memory (see its error)."
                     : "the boundary points of the pieces near this one: " + error;
  }
  if (messages)
  {
    boundary = std::move(messages->boundary);
  }
  return {};
}
} // namespace

class vtkProgressiveTetrahedralMesh::vtkInternals
{
public:
  // Clears a stale abort (see AbortLatch).
  vtkDiamonds::AbortLatch Abort;
  std::optional<rust::Box<bridge::Progressive>> Progressive;
  Key Built;
  // The last build that failed on its input, and why: the same input and settings report it again
  // without another attempt (under MPI, without making every rank rebuild). A build that ran out of
  // memory is not remembered: it may succeed once memory is free.
  std::optional<Key> Failed;
  std::string FailedWhy;
  // The tetrahedralised input when the input had other cells (kept: the key points at it).
  vtkSmartPointer<vtkUnstructuredGrid> Tetrahedra;
  vtkUnstructuredGrid* TetrahedralisedFrom = nullptr;
  vtkMTimeType TetrahedralisedTime = 0;
};

//------------------------------------------------------------------------------
vtkProgressiveTetrahedralMesh::vtkProgressiveTetrahedralMesh()
  : TargetReduction(0.9)
  , MaximumFieldError(0.0)
  , GeometryWeight(1.0)
  , FieldWeight(1.0)
  , ShapeWeight(0.0)
  , PreserveBoundary(1)
  , BoundaryTolerance(0.001)
  , NumberOfSimplifications(0)
  , ComputeIsosurface(0)
  , ContourValues(vtkContourValues::New())
  , Internals(new vtkInternals)
{
  this->SetNumberOfOutputPorts(2);
  this->SetInputArrayToProcess(
    0, 0, 0, vtkDataObject::FIELD_ASSOCIATION_POINTS, vtkDataSetAttributes::SCALARS);
}

//------------------------------------------------------------------------------
vtkProgressiveTetrahedralMesh::~vtkProgressiveTetrahedralMesh()
{
  delete this->Internals;
  this->ContourValues->Delete();
}

//------------------------------------------------------------------------------
vtkMTimeType vtkProgressiveTetrahedralMesh::GetMTime()
{
  return std::max(this->Superclass::GetMTime(), this->ContourValues->GetMTime());
}

void vtkProgressiveTetrahedralMesh::SetValue(int i, double value)
{
  this->ContourValues->SetValue(i, value);
}

double vtkProgressiveTetrahedralMesh::GetValue(int i)
{
  return this->ContourValues->GetValue(i);
}

void vtkProgressiveTetrahedralMesh::SetNumberOfContours(int number)
{
  this->ContourValues->SetNumberOfContours(number);
}

vtkIdType vtkProgressiveTetrahedralMesh::GetNumberOfContours()
{
  return this->ContourValues->GetNumberOfContours();
}

//------------------------------------------------------------------------------
int vtkProgressiveTetrahedralMesh::FillOutputPortInformation(int port, vtkInformation* info)
{
  // Port 0: the level's tetrahedra; port 1: its isosurface.
  info->Set(vtkDataObject::DATA_TYPE_NAME(), port == 0 ? "vtkUnstructuredGrid" : "vtkPolyData");
  return 1;
}

//------------------------------------------------------------------------------
int vtkProgressiveTetrahedralMesh::FillInputPortInformation(int, vtkInformation* info)
{
  info->Set(vtkAlgorithm::INPUT_REQUIRED_DATA_TYPE(), "vtkUnstructuredGrid");
  return 1;
}

//------------------------------------------------------------------------------
int vtkProgressiveTetrahedralMesh::RequestData(
  vtkInformation*, vtkInformationVector** inputVector, vtkInformationVector* outputVector)
try
{
  const vtkDiamonds::AbortLatch::Execution execution(this, this->Internals->Abort);
  vtkUnstructuredGrid* input = vtkUnstructuredGrid::GetData(inputVector[0]);
  vtkUnstructuredGrid* output = vtkUnstructuredGrid::GetData(outputVector, 0);
  vtkPolyData* surface = vtkPolyData::GetData(outputVector, 1);
  if (surface)
  {
    surface->Initialize();
  }
  if (!input || !output)
  {
    vtkErrorMacro(<< "Progressive Tetrahedral Mesh needs a vtkUnstructuredGrid input.");
    return 0;
  }
  output->Initialize();
  vtkInternals& in = *this->Internals;
  // Under MPI (a piece per rank): every rank takes part in the collective steps below, so no rank
  // leaves before them; a rank whose piece is empty outputs nothing.
  vtkMultiProcessController* controller = vtkDiamonds::Pieces::DistributedController();
  const vtkIdType cells = input->GetNumberOfCells();
  if (cells == 0 && !controller)
  {
    vtkErrorMacro(<< "Progressive Tetrahedral Mesh: the input has no cells.");
    return 0;
  }
  // ---- Checks, each failure reported: tetrahedra (other cells are tetrahedralised first) and the
  // field of the error (one point array, one component).
  vtkUnstructuredGrid* tets = input;
  vtkDataArray* array = nullptr;
  vtkMTimeType inputTime = 0;
  const auto check = [&]() -> bool
  {
    // The times of the input's points, cells and point arrays (the data object's and its point
    // data's own MTimes move on every pipeline pass).
    inputTime =
      std::max({ input->GetPoints() ? input->GetPoints()->GetMTime() : 0, input->GetCells()->GetMTime(),
        input->GetCellTypesArray()->GetMTime() });
    for (int a = 0; a < input->GetPointData()->GetNumberOfArrays(); ++a)
    {
      if (vtkAbstractArray* pointArray = input->GetPointData()->GetAbstractArray(a))
      {
        inputTime = std::max(inputTime, pointArray->GetMTime());
      }
    }

    // ---- Tetrahedra only: other cells are tetrahedralised first.
    const unsigned char* types = input->GetCellTypesArray()->GetPointer(0);
    const bool onlyTets = std::all_of(types, types + input->GetNumberOfCells(),
      [](unsigned char type) { return type == VTK_TETRA; });
    if (!onlyTets)
    {
      if (!in.Tetrahedra || in.TetrahedralisedFrom != input || in.TetrahedralisedTime != inputTime)
      {
        vtkNew<vtkDataSetTriangleFilter> tetrahedralize;
        tetrahedralize->TetrahedraOnlyOn();
        tetrahedralize->SetInputData(input);
        tetrahedralize->Update();
        in.Tetrahedra = tetrahedralize->GetOutput();
        in.TetrahedralisedFrom = input;
        in.TetrahedralisedTime = inputTime;
      }
      tets = in.Tetrahedra;
      vtkWarningMacro(<< "Progressive Tetrahedral Mesh: the input has cells other than tetrahedra; "
                         "it was tetrahedralised first ("
                      << tets->GetNumberOfCells() << " tetrahedra).");
      if (tets->GetNumberOfCells() == 0)
      {
        vtkErrorMacro(<< "Progressive Tetrahedral Mesh: the input has no 3-D cells to tetrahedralise.");
        return false;
      }
    }

    // ---- The field of the error: one point array, one component.
    int association = vtkDataObject::FIELD_ASSOCIATION_POINTS;
    array = this->GetInputArrayToProcess(0, tets, association);
    if (!array || association != vtkDataObject::FIELD_ASSOCIATION_POINTS)
    {
      vtkErrorMacro(<< "Progressive Tetrahedral Mesh needs a point-data array (Scalars) to measure "
                       "the field error on; the input has none selected.");
      return false;
    }
    if (array->GetNumberOfComponents() != 1)
    {
      vtkErrorMacro(<< "Progressive Tetrahedral Mesh: Scalars '" << array->GetName() << "' has "
                    << array->GetNumberOfComponents() << " components; choose a single-component array.");
      return false;
    }
    return true;
  };
  const bool ok = cells == 0 || check();
  Key key;
  if (ok && cells > 0)
  {
    key.Input = input;
    key.InputTime = inputTime;
    key.Array = array;
    key.ArrayTime = array->GetMTime();
    key.Weights[0] = this->GeometryWeight;
    key.Weights[1] = this->FieldWeight;
    key.Weights[2] = this->ShapeWeight;
    key.Preserve = this->PreserveBoundary != 0;
    key.Tolerance = this->BoundaryTolerance;
  }
  const bool failedBefore = ok && cells > 0 && in.Failed && *in.Failed == key;
  bool build = ok && cells > 0 && !failedBefore && (!in.Progressive || !(in.Built == key));

  // ---- What the sequence is computed from: the points, tetrahedra and scalars as the core takes
  // them, the whole mesh's bounds and, under MPI, the other pieces' boundary points.
  std::vector<double> flatPoints;
  std::vector<double> flatScalars;
  std::vector<std::int64_t> flatCorners;
  const auto flatten = [&]
  {
    const vtkIdType n = tets->GetNumberOfPoints();
    const vtkIdType m = tets->GetNumberOfCells();
    flatPoints.resize(3 * static_cast<std::size_t>(n));
    flatScalars.resize(static_cast<std::size_t>(n));
    for (vtkIdType p = 0; p < n; ++p)
    {
      tets->GetPoint(p, &flatPoints[3 * p]);
      flatScalars[p] = array->GetComponent(p, 0);
    }
    flatCorners.resize(4 * static_cast<std::size_t>(m));
    for (vtkIdType c = 0; c < m; ++c)
    {
      vtkIdType npts = 0;
      const vtkIdType* ids = nullptr;
      tets->GetCellPoints(c, npts, ids);
      for (int k = 0; k < 4; ++k)
      {
        flatCorners[4 * c + k] = ids[k];
      }
    }
  };
  // Under MPI, Distributed flattens (it must also when only another rank builds, and a rank out
  // of memory for it still takes part in the collective steps).
  if (build && !controller)
  {
    flatten();
  }
  std::array<double, 6> bounds{};
  if (cells > 0 && ok)
  {
    tets->GetBounds(bounds.data());
  }
  rust::Vec<std::uint32_t> boundary;
  std::vector<double> seamWith;
  if (controller)
  {
    const std::string stopped =
      Distributed(controller, ok, cells, build, bounds, flatten, flatPoints, flatCorners, boundary,
        seamWith);
    if (!stopped.empty())
    {
      if (ok)
      {
        vtkErrorMacro(<< "Progressive Tetrahedral Mesh: " << stopped);
      }
      return 0;
    }
    if (cells == 0)
    {
      return 1; // an empty piece of a distributed mesh
    }
  }
  else if (!ok)
  {
    return 0;
  }
  if (failedBefore && !build)
  {
    vtkErrorMacro(<< in.FailedWhy);
    return 0;
  }

  // ---- The sequence: computed once per input and settings (under MPI, and whenever another
  // rank's piece changed).
  if (build)
  {
    in.Progressive.reset();
    bridge::ProgressiveSpec spec;
    spec.geometry_weight = this->GeometryWeight;
    spec.field_weight = this->FieldWeight;
    spec.shape_weight = this->ShapeWeight;
    spec.preserve_boundary = this->PreserveBoundary != 0;
    spec.boundary_tolerance = this->BoundaryTolerance;
    std::copy(bounds.begin(), bounds.end(), spec.whole_bounds.begin());
    try
    {
      in.Progressive.emplace(bridge::build_progressive(
        rust::Slice<const double>(flatPoints.data(), flatPoints.size()),
        rust::Slice<const std::int64_t>(flatCorners.data(), flatCorners.size()),
        rust::Slice<const double>(flatScalars.data(), flatScalars.size()), spec,
        rust::Slice<const std::uint32_t>(boundary.data(), boundary.size()),
        rust::Slice<const double>(seamWith.data(), seamWith.size())));
    }
    catch (const rust::Error& e)
    {
      const std::string why = e.what();
      in.FailedWhy =
        std::string("Progressive Tetrahedral Mesh failed on '") + array->GetName() + "': " + why;
      if (!bridge::ran_out_of_memory())
      {
        in.Failed = key;
      }
      vtkErrorMacro(<< in.FailedWhy);
      return 0;
    }
    in.Failed.reset();
    in.Built = key;
    // The copies the core took are no longer needed while the output is built.
    std::vector<double>().swap(flatPoints);
    std::vector<double>().swap(flatScalars);
    std::vector<std::int64_t>().swap(flatCorners);
    ++this->NumberOfSimplifications;
  }
  bridge::Progressive& pm = **in.Progressive;

  // ---- The collapse sequence as far as TargetReduction asks (continued, not recomputed, when a
  // later execution asks for more; an abort keeps the collapses made).
  {
    vtkDiamonds::ProgressForwarder progress(this, 0.0, 0.9);
    try
    {
      pm.reduce_for(this->TargetReduction, progress);
      const rust::String warning = pm.reduction_warning(this->TargetReduction);
      if (!warning.empty())
      {
        vtkWarningMacro(<< "Progressive Tetrahedral Mesh, array \"" << array->GetName() << "\", "
                        << "TargetReduction " << this->TargetReduction << ": "
                        << std::string(warning));
      }
    }
    catch (const rust::Error& e)
    {
      if (progress.Aborted)
      {
        return 1;
      }
      vtkErrorMacro(<< "Progressive Tetrahedral Mesh failed on '" << array->GetName()
                    << "': " << e.what());
      return 0;
    }
  }

  // ---- The level: replayed from the current one (the isosurface updated under each split).
  try
  {
    std::vector<double> isovalues;
    if (this->ComputeIsosurface)
    {
      for (vtkIdType k = 0; k < this->ContourValues->GetNumberOfContours(); ++k)
      {
        isovalues.push_back(this->ContourValues->GetValue(static_cast<int>(k)));
      }
    }
    pm.set_isovalues(rust::Slice<const double>(isovalues.data(), isovalues.size()));
    pm.set_level(pm.level_for(this->TargetReduction, this->MaximumFieldError));
  }
  catch (const rust::Error& e)
  {
    vtkErrorMacro(<< "Progressive Tetrahedral Mesh: " << e.what());
    return 0;
  }
  this->UpdateProgress(0.95);
  if (this->CheckAbort()) // also when no collapse was needed (the core reported no progress)
  {
    return 1;
  }

  // ---- Output: the level's points with all point data, its tetrahedra, FieldError. The core
  // writes coordinates, connectivity and errors straight into the output's arrays, in parallel.
  rust::Slice<const std::uint32_t> pointIds = pm.level_point_ids();
  const vtkIdType np = static_cast<vtkIdType>(pointIds.size());
  const vtkIdType nt = static_cast<vtkIdType>(pm.level_tet_count());
  vtkNew<vtkDoubleArray> coordinates;
  coordinates->SetNumberOfComponents(3);
  vtkDiamonds::Allocate(coordinates, 3 * np);
  vtkNew<vtkTypeInt32Array> connectivity32;
  std::vector<std::uint32_t> connectivity64; // more points than 32-bit ids hold (never in practice)
  const bool narrow = np <= std::numeric_limits<vtkTypeInt32>::max();
  std::uint32_t* corners = nullptr;
  if (narrow)
  {
    vtkDiamonds::Allocate(connectivity32, 4 * nt);
    // Same size and layout; ids below 2^31 read the same either way.
    corners = reinterpret_cast<std::uint32_t*>(connectivity32->GetPointer(0));
  }
  else
  {
    connectivity64.resize(static_cast<std::size_t>(4 * nt));
    corners = connectivity64.data();
  }
  vtkNew<vtkDoubleArray> fieldError;
  fieldError->SetName("FieldError");
  vtkDiamonds::Allocate(fieldError, nt);
  vtkNew<vtkPoints> points;
  points->SetData(coordinates);
  output->SetPoints(points);
  // Every point array passed through, as CopyData would, gathered by the core in parallel.
  std::string passError;
  try
  {
    pm.fill_level(rust::Slice<double>(coordinates->GetPointer(0), static_cast<std::size_t>(3 * np)),
      rust::Slice<std::uint32_t>(corners, static_cast<std::size_t>(4 * nt)),
      rust::Slice<double>(fieldError->GetPointer(0), static_cast<std::size_t>(nt)));
    if (!vtkDiamonds::PassPointData(
          tets->GetPointData(), output->GetPointData(), np,
          [&](vtkDataArray*, rust::Slice<const std::uint8_t> source, std::size_t tupleBytes,
            rust::Slice<std::uint8_t> target)
          { pm.gather_level_point_values(source, tupleBytes, target); },
          [&](rust::Slice<std::int64_t> ids)
          { std::copy(pointIds.begin(), pointIds.end(), ids.begin()); },
          passError))
    {
      output->Initialize(); // no partial output
      vtkErrorMacro(<< "Progressive Tetrahedral Mesh: " << passError);
      return 0;
    }
  }
  catch (const rust::Error& e)
  {
    output->Initialize();
    vtkErrorMacro(<< "Progressive Tetrahedral Mesh: " << e.what());
    return 0;
  }
  if (narrow)
  {
    vtkNew<vtkCellArray> cells;
    cells->SetData(4, connectivity32);
    vtkDiamonds::SetTetrahedra(output, cells);
  }
  else
  {
    vtkDiamonds::SetTetrahedra(output,
      vtkDiamonds::FixedSizeCells(4,
        rust::Slice<const std::uint32_t>(connectivity64.data(), connectivity64.size()), np));
  }
  output->GetCellData()->AddArray(fieldError);

  vtkFieldData* fieldData = output->GetFieldData();
  fieldData->PassData(input->GetFieldData());
  fieldData->AddArray(OneValue<vtkIdTypeArray>("Level", static_cast<vtkIdType>(pm.current_level())));
  fieldData->AddArray(
    OneValue<vtkIdTypeArray>("NumberOfLevels", static_cast<vtkIdType>(pm.number_of_levels())));
  fieldData->AddArray(OneValue<vtkIdTypeArray>("NumberOfTetrahedra", nt));
  fieldData->AddArray(OneValue<vtkDoubleArray>("MaximumFieldError", pm.level_max_field_error()));
  fieldData->AddArray(OneValue<vtkDoubleArray>("RMSFieldError", pm.level_rms_field_error()));
  if (surface && this->ComputeIsosurface)
  {
    rust::Slice<const double> isoPoints = pm.iso_points();
    rust::Slice<const double> isoValues = pm.iso_values();
    rust::Slice<const std::uint32_t> triangles = pm.iso_triangles();
    const vtkIdType nip = static_cast<vtkIdType>(isoValues.size());
    surface->SetPoints(vtkDiamonds::PointsFrom(isoPoints));
    surface->SetPolys(vtkDiamonds::FixedSizeCells(3, triangles, nip));
    surface->GetPointData()->SetScalars(vtkDiamonds::NamedArray<vtkDoubleArray>(
      array->GetName() ? array->GetName() : "Isovalue", nip, isoValues.data()));
  }
  if (pm.merged_points() > 0 || pm.dropped_tets() > 0)
  {
    vtkWarningMacro(<< "Progressive Tetrahedral Mesh: " << pm.merged_points()
                    << " coincident points merged, " << pm.dropped_tets()
                    << " flat tetrahedra (a corner repeated, in the input or after merging) dropped.");
  }
  this->UpdateProgress(1.0);
  return 1;
}
catch (const std::bad_alloc& e)
{
  vtkDiamonds::ReportOutOfMemory(this, "Progressive Tetrahedral Mesh", outputVector, e);
  return 0;
}

//------------------------------------------------------------------------------
void vtkProgressiveTetrahedralMesh::PrintSelf(ostream& os, vtkIndent indent)
{
  this->Superclass::PrintSelf(os, indent);
  os << indent << "TargetReduction: " << this->TargetReduction << "\n";
  os << indent << "MaximumFieldError: " << this->MaximumFieldError << "\n";
  os << indent << "GeometryWeight: " << this->GeometryWeight << "\n";
  os << indent << "FieldWeight: " << this->FieldWeight << "\n";
  os << indent << "ShapeWeight: " << this->ShapeWeight << "\n";
  os << indent << "PreserveBoundary: " << (this->PreserveBoundary ? "On" : "Off") << "\n";
  os << indent << "BoundaryTolerance: " << this->BoundaryTolerance << "\n";
  os << indent << "NumberOfSimplifications: " << this->NumberOfSimplifications << "\n";
  os << indent << "ComputeIsosurface: " << (this->ComputeIsosurface ? "On" : "Off") << "\n";
  os << indent << "NumberOfContours: " << this->ContourValues->GetNumberOfContours() << "\n";
}
