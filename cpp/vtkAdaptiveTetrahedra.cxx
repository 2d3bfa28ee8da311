#include "vtkAdaptiveTetrahedra.h"

#include "vtkDataArray.h"
#include "vtkDataSetAttributes.h"
#include "vtkDoubleArray.h"
#include "vtkFieldData.h"
#include "vtkCellArray.h"
#include "vtkCellData.h"
#include "vtkCellType.h"
#include "vtkFloatArray.h"
#include "vtkIdTypeArray.h"
#include "vtkImageData.h"
#include "vtkPointData.h"
#include "vtkPoints.h"
#include "vtkUnsignedCharArray.h"
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
#include "vtkDiamondsPieces.h"
#include "vtkDiamondsProgress.h"

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstddef>
#include <optional>
#include <string>

#if defined(__GLIBC__)
#include <malloc.h> // malloc_trim
#endif

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
  // Clears a stale abort (see AbortLatch).
  vtkDiamonds::AbortLatch Abort;
  // The mesh query does not read the samples again: no need to keep them.
  vtkDiamonds::HierarchyCache Cache{ vtkDiamonds::HierarchyCache::Use::Tetrahedra };

  // On more than one rank: this rank's part of the hierarchy and what it was built from (this
  // rank's input, every rank's extent and the whole grid).
  struct PieceKey
  {
    vtkDiamonds::InputKey Input;
    std::vector<std::int64_t> Extents;
    std::array<double, 9> Whole{};
    bool operator==(const PieceKey& o) const
    {
      return Input == o.Input && Extents == o.Extents && Whole == o.Whole;
    }
  };
  std::optional<rust::Box<bridge::PieceHierarchy>> Piece;
  PieceKey PieceBuilt;
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
try
{
  const vtkDiamonds::AbortLatch::Execution execution(this, this->Internals->Abort);
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
  if (!vtkDiamonds::CheckBudget(this, this->MaximumNumberOfTetrahedra))
  {
    return 0;
  }

  if (vtkMultiProcessController* controller = vtkDiamonds::Pieces::DistributedController())
  {
    return this->RequestDistributed(controller, inputVector, input, output);
  }

  // ---- The array to approximate, and its hierarchy (built only when the array or the geometry
  // changed).
  int association = vtkDataObject::FIELD_ASSOCIATION_POINTS;
  vtkDataArray* selected = this->GetInputArrayToProcess(0, inputVector, association);
  int result = 0;
  vtkDataArray* array =
    vtkDiamonds::ImageArrayToProcess(this, Text, input, selected, association, result);
  if (!array ||
    !this->Internals->Cache.Prepare(
      this, Text, input, array, 0.0, 0.8, this->NumberOfHierarchyBuilds, result))
  {
    return result;
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
    const rust::String warning = hierarchy.budget_warning(query.max_tetrahedra);
    if (!warning.empty())
    {
      vtkWarningMacro(<< "Adaptive Tetrahedra, array \"" << array->GetName()
                      << "\": " << std::string(warning));
    }
  }
  catch (const rust::Error& e)
  {
    vtkErrorMacro(<< "Adaptive Tetrahedra query failed: " << e.what());
    return 0;
  }
  this->UpdateProgress(0.9);

#if defined(__GLIBC__)
  // The build's and the refinement's temporary vectors are freed by now, but glibc keeps their
  // pages in its arenas, most in the worker threads' ones, which the output arrays allocated below
  // on this thread do not reuse: give them back to the system first. Measured peak RSS growth of
  // a first execution: bonsai 256³ at tolerance 8 506 -> 490 MiB for an output of 406 MiB, fuel
  // 64³ at 8 4.2 -> 3.9 MiB for 2.8 MiB.
  malloc_trim(0);
#endif

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
catch (const std::bad_alloc& e)
{
  vtkDiamonds::ReportOutOfMemory(this, "Adaptive Tetrahedra", outputVector, e);
  return 0;
}

//------------------------------------------------------------------------------
int vtkAdaptiveTetrahedra::RequestDistributed(vtkMultiProcessController* controller,
  vtkInformationVector** inputVector, vtkImageData* input, vtkUnstructuredGrid* output)
{
  const auto started = std::chrono::steady_clock::now();
  vtkInformation* inInfo = inputVector[0]->GetInformationObject(0);
  const bool empty = input->GetNumberOfPoints() == 0;

  // ---- The whole image and every rank's piece (all ranks take part in every step below; a
  // failure on one rank is agreed on before the next collective step).
  vtkDiamonds::Pieces pieces(controller, inInfo, input);

  // ---- This piece's samples (an empty piece has none and reads no array). Each step between
  // two collective ones runs in Pieces::Run: whatever fails on this rank (out of memory among it)
  // is reported here and agreed on, so that all ranks leave together with empty outputs.
  const auto run = [&](const char* failure, auto&& work) {
    return vtkDiamonds::Pieces::Run(this, Text.Name, failure, work);
  };
  const auto agree = [&](bool mine, const char* what) {
    if (pieces.Agree(this, Text.Name, mine, what))
    {
      return true;
    }
    output->Initialize();
    return false;
  };
  vtkDataArray* array = nullptr;
  vtkSmartPointer<vtkDataArray> samples;
  bridge::ScalarType type = bridge::ScalarType::F64;
  bool ok = empty || run("cannot read its input", [&] {
    int association = vtkDataObject::FIELD_ASSOCIATION_POINTS;
    vtkDataArray* selected = this->GetInputArrayToProcess(0, inputVector, association);
    return vtkDiamonds::CheckAxisAligned(this, Text, input) &&
      (array = vtkDiamonds::SelectPointArray(this, Text, input, selected, association)) &&
      vtkDiamonds::CoreSamples(this, Text, array, samples, type);
  });
  if (!agree(ok, "reading the input"))
  {
    return pieces.Failed();
  }
  const auto bytesOf = [](vtkDataArray* a) {
    return a ? rust::Slice<const std::uint8_t>(static_cast<const std::uint8_t*>(a->GetVoidPointer(0)),
                 static_cast<std::size_t>(a->GetNumberOfValues()) * a->GetDataTypeSize())
             : rust::Slice<const std::uint8_t>();
  };

  // ---- This rank's part of the hierarchy: rebuilt on every rank when any rank's input changed.
  vtkInternals::PieceKey key;
  key.Input = vtkDiamonds::InputKey(input, array);
  key.Extents.assign(pieces.Extents().begin(), pieces.Extents().end());
  for (int axis = 0; axis < 3; ++axis)
  {
    key.Whole[axis] = static_cast<double>(pieces.Whole().dims[axis]);
    key.Whole[3 + axis] = pieces.Whole().origin[axis];
    key.Whole[6 + axis] = pieces.Whole().spacing[axis];
  }
  const bool stale = !this->Internals->Piece || !(this->Internals->PieceBuilt == key);
  if (pieces.Sum(stale ? 1 : 0) > 0)
  {
    this->Internals->Piece.reset();
    const char* cannotBuild = "cannot build this rank's hierarchy";
    // The samples of the piece's lattice held by other ranks, asked of them as boxes (none asked
    // for after a failure, but the fetch is collective: every rank takes part).
    std::optional<bridge::SampleRequests> requests;
    ok = run(cannotBuild, [&] {
      requests.emplace(bridge::piece_requests(pieces.Whole(), pieces.Extents(), pieces.Rank()));
      return true;
    });
    std::vector<vtkDataArray*> arrays;
    if (samples)
    {
      arrays.push_back(samples);
    }
    std::string error;
    std::vector<vtkSmartPointer<vtkDataArray>> fetched;
    const bool got = requests ? pieces.FetchBoxes(*requests, arrays, fetched, error)
                              : pieces.FetchBoxes(bridge::SampleRequests{}, arrays, fetched, error);
    if (ok && !got)
    {
      vtkErrorMacro(<< "Adaptive Tetrahedra " << cannotBuild << ": " << error);
    }
    requests.reset();
    ok = ok && got && run(cannotBuild, [&] {
      vtkDiamonds::ProgressForwarder progress(this, 0.0, 0.6);
      try
      {
        this->Internals->Piece.emplace(bridge::build_piece_hierarchy(pieces.Whole(),
          pieces.Extents(), pieces.Rank(), type, bytesOf(samples),
          bytesOf(fetched.empty() ? nullptr : fetched[0].GetPointer()), progress));
      }
      catch (const rust::Error&)
      {
        if (!progress.Aborted)
        {
          throw;
        }
        return false; // aborted: no error
      }
      return true;
    });
    fetched.clear();
    if (!agree(ok, "building the hierarchy"))
    {
      this->Internals->Piece.reset();
      return pieces.Failed();
    }
    // The coarse errors (one per point of the coarse sublattice, as many on every rank), combined.
    bridge::PieceHierarchy& built = **this->Internals->Piece;
    std::vector<double> coarse;
    ok = run(cannotBuild, [&] {
      coarse.assign(built.coarse_errors().begin(), built.coarse_errors().end());
      return true;
    });
    if (!agree(ok, "building the hierarchy"))
    {
      this->Internals->Piece.reset();
      return pieces.Failed();
    }
    ok = pieces.MaxInPlace(coarse, error);
    if (!ok)
    {
      vtkErrorMacro(<< "Adaptive Tetrahedra " << cannotBuild << ": " << error);
    }
    ok = ok && run(cannotBuild, [&] {
      built.combine_coarse_errors({ coarse.data(), coarse.size() });
      return true;
    });
    if (!agree(ok, "building the hierarchy"))
    {
      this->Internals->Piece.reset();
      return pieces.Failed();
    }
    this->Internals->PieceBuilt = key;
    ++this->NumberOfHierarchyBuilds;
  }
  this->UpdateProgress(0.6);
  const bridge::PieceHierarchy& piece = **this->Internals->Piece;

  // ---- Refinement in rounds, until no rank has a split diamond to send.
  bridge::QuerySpec query;
  query.tolerance = this->Tolerance;
  query.max_tetrahedra = static_cast<std::size_t>(this->MaximumNumberOfTetrahedra);
  query.use_region_of_interest = this->UseRegionOfInterest != 0;
  std::copy(this->RegionOfInterest, this->RegionOfInterest + 6, query.region_of_interest.begin());
  std::optional<rust::Box<bridge::PieceRefinement>> refinement;
  ok = run("query failed", [&] {
    refinement.emplace(piece.start_refinement(query));
    return true;
  });
  if (!agree(ok, "the query"))
  {
    return pieces.Failed();
  }
  int rounds = 0;
  const char* refinementFailed = "refinement failed";
  for (;;)
  {
    // The diamonds split since the last round, addressed to the ranks whose pieces they reach.
    std::optional<bridge::SplitMessages> outgoing;
    ok = ok && run(refinementFailed, [&] {
      outgoing.emplace(piece.outgoing(**refinement, pieces.Extents()));
      return true;
    });
    if (!agree(ok, "the refinement"))
    {
      return pieces.Failed();
    }
    std::vector<std::int32_t> received;
    std::string error;
    bool moved = false;
    ok = pieces.Exchange(
      rust::Slice<const std::size_t>(outgoing->counts.data(), outgoing->counts.size()),
      outgoing->centers.data(), received, moved, error);
    if (!ok)
    {
      vtkErrorMacro(<< "Adaptive Tetrahedra " << refinementFailed << ": " << error);
    }
    if (!moved)
    {
      // No rank split a diamond another rank needs: every piece is closed (every rank leaves
      // here alike; a failure goes on to the steps below, which all ranks take together).
      break;
    }
    ok = ok && run(refinementFailed, [&] {
      piece.receive(**refinement, { received.data(), received.size() });
      return true;
    });
    ++rounds;
    this->UpdateProgress(std::min(0.8, 0.6 + 0.02 * rounds));
  }

  // ---- This rank's tetrahedra (counted), and the point data of their points held by other ranks.
  std::optional<rust::Box<bridge::MeshPlan>> plan;
  rust::Vec<std::uint64_t> remote; // ascending whole-grid indices
  ok = ok && run("could not extract this rank's mesh", [&] {
    plan.emplace(piece.piece_plan(
      std::move(*refinement), pieces.Extents(), static_cast<std::size_t>(pieces.Rank())));
    remote = (*plan)->piece_remote_point_ids();
    return true;
  });
  refinement.reset();
  if (!ok)
  {
    // Fetch nothing, but take part in the fetch below.
    remote.clear();
  }
  this->UpdateProgress(0.85);
  vtkPointData* inPD = input->GetPointData();
  std::vector<vtkDataArray*> pointArrays;
  for (int i = 0; !empty && i < inPD->GetNumberOfArrays(); ++i)
  {
    if (vtkDataArray* a = inPD->GetArray(i))
    {
      pointArrays.push_back(a);
    }
  }
  std::vector<vtkSmartPointer<vtkDataArray>> fetched;
  std::string error;
  if (!pieces.Fetch({ remote.data(), remote.size() }, pointArrays, fetched, error) && ok)
  {
    vtkErrorMacro(<< "Adaptive Tetrahedra could not fetch point data from other ranks: " << error);
    ok = false;
  }
  if (!agree(ok, "fetching point data"))
  {
    return pieces.Failed();
  }

  // ---- Output, written by the core into the arrays: each point array's tuples from this rank's
  // piece or from those fetched.
  double rankMaxError = 0.0;
  ok = run("could not write its output", [&] {
    const bridge::MeshPlan& p = **plan;
    std::string writeError;
    const bool written = vtkDiamonds::WritePlan(
      p, pieces.Frame(), inPD,
      [&](vtkDataArray* in, rust::Slice<const std::uint8_t> local, std::size_t tupleBytes,
        rust::Slice<std::uint8_t> target)
      {
        const auto a = std::find(pointArrays.begin(), pointArrays.end(), in) - pointArrays.begin();
        const vtkSmartPointer<vtkDataArray> values = vtkDiamonds::Contiguous(fetched.at(a));
        const auto* bytes = static_cast<const std::uint8_t*>(values->GetVoidPointer(0));
        p.gather_piece_point_values(local,
          rust::Slice<const std::uint8_t>(bytes, tupleBytes * values->GetNumberOfTuples()),
          tupleBytes, target);
      },
      nullptr,
      [&](rust::Slice<std::int32_t> c, rust::Slice<std::int32_t> o, rust::Slice<std::uint8_t> d,
        rust::Slice<float> e) { return piece.write_piece_tets_i32(p, c, o, d, e); },
      [&](rust::Slice<std::int64_t> c, rust::Slice<std::int64_t> o, rust::Slice<std::uint8_t> d,
        rust::Slice<float> e) { return piece.write_piece_tets_i64(p, c, o, d, e); },
      true, output, rankMaxError, writeError);
    if (!written)
    {
      output->Initialize();
      vtkErrorMacro(<< "Adaptive Tetrahedra could not write its output: " << writeError);
    }
    return written;
  });
  fetched.clear();
  plan.reset();
  if (!agree(ok, "writing the output"))
  {
    return pieces.Failed();
  }
  const vtkIdType numTets = output->GetNumberOfCells();

  std::vector<double> maxError{ rankMaxError };
  if (!pieces.MaxInPlace(maxError, error))
  {
    vtkErrorMacro(<< "Adaptive Tetrahedra could not combine the ranks' errors: " << error);
    output->Initialize();
    return 0;
  }
  const vtkIdType total = pieces.Sum(numTets);
  vtkFieldData* fieldData = output->GetFieldData();
  if (!empty)
  {
    fieldData->PassData(input->GetFieldData());
  }
  fieldData->AddArray(OneValue<vtkDoubleArray>("Tolerance", this->Tolerance));
  fieldData->AddArray(OneValue<vtkIdTypeArray>("NumberOfTetrahedra", total));
  fieldData->AddArray(OneValue<vtkDoubleArray>("MaximumError", maxError[0]));
  fieldData->AddArray(OneValue<vtkIdTypeArray>("RefinementRounds", rounds));
  pieces.AddFigures(fieldData, "TetrahedraPerRank", numTets, started);
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
