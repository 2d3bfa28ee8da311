#include "vtkAdaptiveIntervalVolume.h"

#include "vtkCellArray.h"
#include "vtkCellData.h"
#include "vtkDataArray.h"
#include "vtkDataSetAttributes.h"
#include "vtkDoubleArray.h"
#include "vtkFieldData.h"
#include "vtkIdTypeArray.h"
#include "vtkImageData.h"
#include "vtkInformation.h"
#include "vtkInformationVector.h"
#include "vtkObjectFactory.h"
#include "vtkPointData.h"
#include "vtkPoints.h"
#include "vtkUnsignedCharArray.h"
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
#include <chrono>
#include <cmath>
#include <cstddef>
#include <optional>
#include <string>
#include <vector>

vtkStandardNewMacro(vtkAdaptiveIntervalVolume);

namespace
{
namespace bridge = diamonds::bridge;
using vtkDiamonds::FixedSizeCells;
using vtkDiamonds::NamedArray;
using vtkDiamonds::OneValue;

const vtkDiamonds::FilterText Text = { "Adaptive Interval Volume", "extract the interval volume of",
  "extracts the interval volume of", "Scalars" };

// Fills `output` with the tetrahedra of `volume`: points, every point array of `in` copied at
// samples and interpolated along the mesh edge at new points (from the tuples of `in` that
// `sources` name, two per point), cell data "Level". Throws vtkDiamonds::OutOfMemory.
void FillVolume(const bridge::IntervalVolume& volume, vtkPointData* in,
  rust::Slice<const std::uint32_t> sources, vtkUnstructuredGrid* output)
{
  const rust::Slice<const double> weights = volume.weights();
  const rust::Slice<const std::uint8_t> levels = volume.levels();
  const vtkIdType numPoints = static_cast<vtkIdType>(weights.size());
  const vtkIdType numTets = static_cast<vtkIdType>(levels.size());
  output->SetPoints(vtkDiamonds::PointsFrom(volume.points()));
  vtkDiamonds::SetTetrahedra(output, FixedSizeCells(4, volume.tets(), numPoints));
  vtkDiamonds::InterpolatePointData(in, nullptr, sources, weights, output->GetPointData());
  output->GetCellData()->AddArray(
    NamedArray<vtkUnsignedCharArray>("Level", numTets, levels.data()));
}
} // namespace

class vtkAdaptiveIntervalVolume::vtkInternals
{
public:
  // Clears a stale abort (see AbortLatch).
  vtkDiamonds::AbortLatch Abort;
  // The extraction reads the samples again: keep them with the hierarchy.
  vtkDiamonds::HierarchyCache Cache{ vtkDiamonds::HierarchyCache::Use::Isosurfaces };

  // On more than one rank: the whole image of the processed array this rank put together.
  vtkDiamonds::WholeImage Whole;
};

//------------------------------------------------------------------------------
vtkAdaptiveIntervalVolume::vtkAdaptiveIntervalVolume()
  : ThresholdRange{ 0.0, 1.0 }
  , Tolerance(0.0)
  , RelativeTolerance(0.0)
  , MaximumNumberOfTetrahedra(0)
  , UseRegionOfInterest(0)
  , RegionOfInterest{ 0.0, 1.0, 0.0, 1.0, 0.0, 1.0 }
  , Hierarchy(HIERARCHY_FULL)
  , NumberOfHierarchyBuilds(0)
  , NumberOfIsodiamondBuilds(0)
  , Internals(new vtkInternals)
{
  // Default: the active point scalars.
  this->SetInputArrayToProcess(
    0, 0, 0, vtkDataObject::FIELD_ASSOCIATION_POINTS, vtkDataSetAttributes::SCALARS);
}

//------------------------------------------------------------------------------
vtkAdaptiveIntervalVolume::~vtkAdaptiveIntervalVolume()
{
  delete this->Internals;
}

//------------------------------------------------------------------------------
int vtkAdaptiveIntervalVolume::FillInputPortInformation(int, vtkInformation* info)
{
  info->Set(vtkAlgorithm::INPUT_REQUIRED_DATA_TYPE(), "vtkImageData");
  return 1;
}

//------------------------------------------------------------------------------
int vtkAdaptiveIntervalVolume::RequestUpdateExtent(
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
vtkIdType vtkAdaptiveIntervalVolume::GetHierarchyMemorySize()
{
  return this->Internals->Cache.GetMemorySize();
}

//------------------------------------------------------------------------------
void vtkAdaptiveIntervalVolume::ReleaseHierarchy()
{
  this->Internals->Cache.Release();
}

//------------------------------------------------------------------------------
int vtkAdaptiveIntervalVolume::RequestData(
  vtkInformation*, vtkInformationVector** inputVector, vtkInformationVector* outputVector)
try
{
  const vtkDiamonds::AbortLatch::Execution execution(this, this->Internals->Abort);
  vtkImageData* input = vtkImageData::GetData(inputVector[0]);
  vtkUnstructuredGrid* output = vtkUnstructuredGrid::GetData(outputVector, 0);
  if (!input || !output)
  {
    vtkErrorMacro(<< "Adaptive Interval Volume needs a vtkImageData input.");
    return 0;
  }
  // Every error below leaves an empty output.
  output->Initialize();
  this->RelativeTolerance = 0.0;
  if (vtkMultiProcessController* controller = vtkDiamonds::Pieces::DistributedController())
  {
    return this->RequestDistributed(controller, inputVector, input, output);
  }

  // ---- Parameters (the range itself is checked by the core, with the same words everywhere).
  if (!std::isfinite(this->Tolerance) || this->Tolerance < 0.0)
  {
    vtkErrorMacro(<< "Tolerance must be a finite number >= 0 (got " << this->Tolerance
                  << "); it is in world units, 0 gives the full-resolution interval volume.");
    return 0;
  }
  if (!vtkDiamonds::CheckBudget(this, this->MaximumNumberOfTetrahedra))
  {
    return 0;
  }
  int association = vtkDataObject::FIELD_ASSOCIATION_POINTS;
  vtkDataArray* selected = this->GetInputArrayToProcess(0, inputVector, association);
  int result = 0;
  vtkDataArray* array =
    vtkDiamonds::ImageArrayToProcess(this, Text, input, selected, association, result);
  if (!array)
  {
    return result;
  }
  const double diagonal = vtkDiamonds::WholeDiagonal(inputVector, input);
  const double relativeTolerance = diagonal > 0.0 ? this->Tolerance / diagonal : 0.0;

  // ---- Hierarchy: built only when the array or the geometry changed.
  vtkDiamonds::HierarchyCache& cache = this->Internals->Cache;
  if (!cache.Prepare(this, Text, input, array, 0.0, 0.3, this->NumberOfHierarchyBuilds, result))
  {
    return result;
  }

  // ---- The isodiamond hierarchy of the range (Relevant, Minimal), kept while the range, the
  // choice and the input stay; dropped with Full.
  const bridge::Isodiamonds* isodiamonds = nullptr;
  if (this->Hierarchy != HIERARCHY_FULL)
  {
    // A region of interest, which its extraction refuses, is refused before the build.
    try
    {
      bridge::check_isodiamond_query(this->UseRegionOfInterest != 0, false);
    }
    catch (const rust::Error& e)
    {
      vtkErrorMacro(<< Text.Name << ", Hierarchy "
                    << (this->Hierarchy == HIERARCHY_MINIMAL ? "Minimal" : "Relevant") << ": "
                    << e.what());
      return 0;
    }
    const std::vector<double> range(this->ThresholdRange, this->ThresholdRange + 2);
    isodiamonds = cache.PrepareIsodiamonds(this, Text, range, this->Hierarchy == HIERARCHY_MINIMAL,
      0.3, 0.5, this->NumberOfIsodiamondBuilds, result);
    if (!isodiamonds)
    {
      return result;
    }
  }
  else
  {
    cache.ReleaseIsodiamonds();
  }
  this->UpdateProgress(0.5);

  // ---- Extraction, with the isosurface state kept with the hierarchy (its cache serves), or
  // from the isodiamond hierarchy (no sample read).
  bridge::IntervalSpec spec;
  spec.range = { this->ThresholdRange[0], this->ThresholdRange[1] };
  spec.tolerance = this->Tolerance;
  spec.max_tetrahedra = static_cast<std::size_t>(this->MaximumNumberOfTetrahedra);
  if (!vtkDiamonds::SetRegionOfInterest(
        this, this->UseRegionOfInterest, this->RegionOfInterest, inputVector, input, spec))
  {
    return 0;
  }
  std::optional<rust::Box<bridge::IntervalVolume>> volume;
  try
  {
    volume.emplace(isodiamonds ? isodiamonds->interval_volume(spec)
                               : cache.GetHierarchy().interval_volume(cache.GetIsoState(),
                                   cache.GetSampleType(), cache.GetSamples(), spec));
    for (const rust::String& warning : (*volume)->warnings())
    {
      vtkWarningMacro(<< "Adaptive Interval Volume, array \"" << array->GetName()
                      << "\": " << std::string(warning));
    }
  }
  catch (const rust::Error& e)
  {
    vtkErrorMacro(<< "Adaptive Interval Volume failed for array \"" << array->GetName()
                  << "\": " << e.what());
    return 0;
  }
  this->UpdateProgress(0.8);
  if (this->CheckAbort())
  {
    return 1;
  }

  // ---- Output.
  FillVolume(**volume, input->GetPointData(), (*volume)->sources(), output);
  this->RelativeTolerance = relativeTolerance;
  vtkFieldData* fieldData = output->GetFieldData();
  fieldData->PassData(input->GetFieldData());
  fieldData->AddArray(OneValue<vtkDoubleArray>("ErrorBound", (*volume)->error_bound()));
  fieldData->AddArray(OneValue<vtkDoubleArray>("Tolerance", this->Tolerance));
  fieldData->AddArray(OneValue<vtkDoubleArray>("RelativeTolerance", relativeTolerance));
  fieldData->AddArray(
    OneValue<vtkDoubleArray>("ReachedTolerance", (*volume)->reached_tolerance()));
  fieldData->AddArray(OneValue<vtkIdTypeArray>("NumberOfTetrahedra", output->GetNumberOfCells()));
  fieldData->AddArray(OneValue<vtkIdTypeArray>("NumberOfPoints", output->GetNumberOfPoints()));
  fieldData->AddArray(
    OneValue<vtkIdTypeArray>("NumberOfLeaves", static_cast<vtkIdType>((*volume)->leaves())));
  fieldData->AddArray(OneValue<vtkIdTypeArray>("HierarchyMemorySize", cache.GetMemorySize()));
  if (isodiamonds)
  {
    const rust::Slice<const double> ladder = isodiamonds->ladder();
    fieldData->AddArray(NamedArray<vtkDoubleArray>(
      "HierarchyLadder", static_cast<vtkIdType>(ladder.size()), ladder.data()));
  }
  this->UpdateProgress(1.0);
  return 1;
}
catch (const std::bad_alloc& e)
{
  vtkDiamonds::ReportOutOfMemory(this, "Adaptive Interval Volume", outputVector, e);
  return 0;
}

//------------------------------------------------------------------------------
int vtkAdaptiveIntervalVolume::RequestDistributed(vtkMultiProcessController* controller,
  vtkInformationVector** inputVector, vtkImageData* input, vtkUnstructuredGrid* output)
{
  const auto started = std::chrono::steady_clock::now();
  const bool empty = input->GetNumberOfPoints() == 0;
  // As Adaptive Isosurface's: every rank takes part in every collective step; each step between
  // two of them runs in Pieces::Run, and a failure on one rank is agreed on before the next.
  vtkDiamonds::Pieces pieces(controller, inputVector[0]->GetInformationObject(0), input);
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

  // ---- Parameters and this piece's arrays (an empty piece reads none).
  bool ok = true;
  if (!std::isfinite(this->Tolerance) || this->Tolerance < 0.0)
  {
    vtkErrorMacro(<< "Tolerance must be a finite number >= 0 (got " << this->Tolerance
                  << "); it is in world units, 0 gives the full-resolution interval volume.");
    ok = false;
  }
  ok = ok && vtkDiamonds::CheckBudget(this, this->MaximumNumberOfTetrahedra);
  if (ok && this->Hierarchy != HIERARCHY_FULL)
  {
    vtkErrorMacro(<< "Hierarchy Relevant and Minimal run on one process: choose Hierarchy Full "
                     "for distributed (MPI) execution.");
    ok = false;
  }
  vtkDataArray* array = nullptr;
  if (ok && !empty)
  {
    ok = run("cannot read its input", [&] {
      int association = vtkDataObject::FIELD_ASSOCIATION_POINTS;
      vtkDataArray* selected = this->GetInputArrayToProcess(0, inputVector, association);
      return vtkDiamonds::CheckAxisAligned(this, Text, input) &&
        (array = vtkDiamonds::SelectPointArray(this, Text, input, selected, association));
    });
  }
  if (!agree(ok, "reading the input"))
  {
    return pieces.Failed();
  }

  // ---- The whole image of the processed array on every rank with a piece, fetched again when
  // any rank's input changed. The other point arrays are not gathered: the output fetches them
  // at its points' sources only.
  const vtkDiamonds::WholeImage::Key key = vtkDiamonds::WholeImage::KeyOf(pieces, input, array);
  if (this->Internals->Whole.Stale(pieces, key))
  {
    this->Internals->Cache.Release();
    if (!this->Internals->Whole.Gather(this, Text.Name, pieces, input, array, key))
    {
      output->Initialize();
      return pieces.Failed();
    }
  }
  this->UpdateProgress(0.1);

  // ---- This rank's share of the interval volume of the whole image.
  vtkImageData* whole = this->Internals->Whole.Get();
  vtkDiamonds::HierarchyCache& cache = this->Internals->Cache;
  std::optional<rust::Box<bridge::IntervalVolume>> volume;
  if (whole)
  {
    const std::string failed =
      std::string("extraction failed for array \"") + array->GetName() + "\"";
    ok = run(failed.c_str(), [&] {
      int result = 0; // the agreement below decides what to return
      if (!cache.Prepare(this, Text, whole, whole->GetPointData()->GetScalars(), 0.1, 0.7,
            this->NumberOfHierarchyBuilds, result))
      {
        return false;
      }
      bridge::IntervalSpec spec;
      spec.range = { this->ThresholdRange[0], this->ThresholdRange[1] };
      spec.tolerance = this->Tolerance;
      spec.max_tetrahedra = static_cast<std::size_t>(this->MaximumNumberOfTetrahedra);
      spec.use_region_of_interest = this->UseRegionOfInterest != 0;
      std::copy(this->RegionOfInterest, this->RegionOfInterest + 6, spec.region_of_interest.begin());
      // The ranks share the error measurement and the bound's check, as Adaptive Isosurface's
      // do (a rank without a piece takes part from its next Agree).
      vtkDiamonds::SharedStep exchange(pieces, this, Text.Name);
      try
      {
        volume.emplace(cache.GetHierarchy().interval_piece(cache.GetIsoState(),
          cache.GetSampleType(), cache.GetSamples(), spec, pieces.Extents(),
          static_cast<std::size_t>(pieces.Rank()), exchange));
      }
      catch (const rust::Error&)
      {
        if (pieces.Stopped())
        {
          return false; // agreed on and reported in the exchange
        }
        throw;
      }
      for (const rust::String& warning : (*volume)->warnings())
      {
        vtkWarningMacro(<< Text.Name << ", array \"" << array->GetName()
                        << "\": " << std::string(warning));
      }
      return true;
    });
    if (!ok)
    {
      volume.reset();
    }
  }
  if (!agree(ok, "the extraction"))
  {
    // Cleared on every rank, so that the next extraction starts alike on all and they exchange
    // alike (ranks that completed their error measurement would otherwise keep it).
    cache.ClearIsosurfaceState();
    return pieces.Failed();
  }
  this->UpdateProgress(0.75);

  // ---- The point data of this rank's points' sources: from its piece, or fetched from the ranks
  // holding them.
  std::optional<rust::Box<bridge::PointSources>> sources;
  ok = !volume || run("could not find where its point data comes from", [&] {
    sources.emplace((*volume)->piece_sources(pieces.Whole(), pieces.OwnExtent()));
    return true;
  });
  vtkNew<vtkPointData> table;
  ok = pieces.SourceTable(this, Text.Name, ok && sources ? &**sources : nullptr,
         empty ? nullptr : input->GetPointData(), nullptr, table) &&
    ok;
  if (!agree(ok, "fetching point data"))
  {
    return pieces.Failed();
  }
  this->UpdateProgress(0.8);

  // ---- Output: this rank's tetrahedra with global point ids; the whole volume's figures.
  std::vector<double> figures{ 0.0, 0.0, 0.0, 0.0 };
  ok = !volume || run("could not write its output", [&] {
    FillVolume(**volume, table, (*sources)->rows(), output);
    output->GetPointData()->SetGlobalIds(
      vtkDiamonds::GlobalPointIds((*volume)->global_point_ids()));
    // The whole volume's points: every one is used by a tetrahedron some rank owns.
    const rust::Slice<const std::uint64_t> ids = (*volume)->global_point_ids();
    const double points = ids.empty() ? 0.0 : static_cast<double>(*std::max_element(ids.begin(), ids.end()) + 1);
    figures = { (*volume)->error_bound(), (*volume)->reached_tolerance(),
      static_cast<double>((*volume)->leaves()), points };
    return true;
  });
  volume.reset();
  sources.reset();
  if (!agree(ok, "the output"))
  {
    return pieces.Failed();
  }
  std::string error;
  if (!pieces.MaxInPlace(figures, error))
  {
    vtkErrorMacro(<< Text.Name << " could not combine the ranks' figures: " << error);
    output->Initialize();
    return 0;
  }
  const vtkIdType numTets = output->GetNumberOfCells();
  const vtkIdType totalTets = pieces.Sum(numTets);
  const double diagonal = pieces.WholeDiagonal();
  const double relativeTolerance = diagonal > 0.0 ? this->Tolerance / diagonal : 0.0;
  this->RelativeTolerance = relativeTolerance;
  vtkFieldData* fieldData = output->GetFieldData();
  if (!empty)
  {
    fieldData->PassData(input->GetFieldData());
  }
  fieldData->AddArray(OneValue<vtkDoubleArray>("ErrorBound", figures[0]));
  fieldData->AddArray(OneValue<vtkDoubleArray>("Tolerance", this->Tolerance));
  fieldData->AddArray(OneValue<vtkDoubleArray>("RelativeTolerance", relativeTolerance));
  fieldData->AddArray(OneValue<vtkDoubleArray>("ReachedTolerance", figures[1]));
  fieldData->AddArray(OneValue<vtkIdTypeArray>("NumberOfTetrahedra", totalTets));
  fieldData->AddArray(
    OneValue<vtkIdTypeArray>("NumberOfPoints", static_cast<vtkIdType>(figures[3])));
  fieldData->AddArray(
    OneValue<vtkIdTypeArray>("NumberOfLeaves", static_cast<vtkIdType>(figures[2])));
  fieldData->AddArray(OneValue<vtkIdTypeArray>("HierarchyMemorySize", cache.GetMemorySize()));
  pieces.AddFigures(fieldData, "TetrahedraPerRank", numTets, started);
  this->UpdateProgress(1.0);
  return 1;
}

//------------------------------------------------------------------------------
void vtkAdaptiveIntervalVolume::PrintSelf(ostream& os, vtkIndent indent)
{
  this->Superclass::PrintSelf(os, indent);
  os << indent << "ThresholdRange: (" << this->ThresholdRange[0] << ", " << this->ThresholdRange[1]
     << ")\n";
  os << indent << "Tolerance: " << this->Tolerance << "\n";
  os << indent << "RelativeTolerance: " << this->RelativeTolerance << "\n";
  os << indent << "MaximumNumberOfTetrahedra: " << this->MaximumNumberOfTetrahedra << "\n";
  os << indent << "UseRegionOfInterest: " << (this->UseRegionOfInterest ? "On" : "Off") << "\n";
  os << indent << "RegionOfInterest: (" << this->RegionOfInterest[0] << ", "
     << this->RegionOfInterest[1] << ", " << this->RegionOfInterest[2] << ", "
     << this->RegionOfInterest[3] << ", " << this->RegionOfInterest[4] << ", "
     << this->RegionOfInterest[5] << ")\n";
  os << indent << "Hierarchy: "
     << (this->Hierarchy == HIERARCHY_FULL ? "Full"
                                             : this->Hierarchy == HIERARCHY_RELEVANT ? "Relevant"
                                                                                     : "Minimal")
     << "\n";
  os << indent << "NumberOfHierarchyBuilds: " << this->NumberOfHierarchyBuilds << "\n";
  os << indent << "NumberOfIsodiamondBuilds: " << this->NumberOfIsodiamondBuilds << "\n";
  os << indent << "HierarchyMemorySize: " << this->GetHierarchyMemorySize() << "\n";
}
