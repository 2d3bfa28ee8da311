#include "vtkDiamondsPieces.h"

#include "vtkDiamondsOutput.h"

#include "vtkAlgorithm.h"
#include "vtkCellData.h"
#include "vtkCommunicator.h"
#include "vtkDataArray.h"
#include "vtkDoubleArray.h"
#include "vtkFieldData.h"
#include "vtkIdList.h"
#include "vtkImageData.h"
#include "vtkInformation.h"
#include "vtkMultiProcessController.h"
#include "vtkNew.h"
#include "vtkPointData.h"
#include "vtkRectilinearGrid.h"
#include "vtkStreamingDemandDrivenPipeline.h"
#include "vtkTypeInt64Array.h"
#include "vtkTypeUInt64Array.h"

#include <algorithm>
#include <cmath>
#include <chrono>
#include <functional>
#include <limits>
#include <numeric>
#include <string>
#include <type_traits>

#include <sys/resource.h>

namespace vtkDiamonds
{
namespace
{
// Message tags of the point fetch (requests, then one response per array).
constexpr int RequestTag = 0x4449; // "DI"
constexpr int ResponseTag = 0x4450;
constexpr int SizeTag = 0x4451;

// Adds the seconds of its lifetime to `total`.
struct Clock
{
  double& Total;
  std::chrono::steady_clock::time_point Start = std::chrono::steady_clock::now();
  ~Clock()
  {
    this->Total +=
      std::chrono::duration<double>(std::chrono::steady_clock::now() - this->Start).count();
  }
};

// A contiguous array of `n` tuples of `like`'s type, components and name; throws OutOfMemory.
vtkSmartPointer<vtkDataArray> SameKind(vtkDataArray* like, vtkIdType n)
{
  auto out = vtkSmartPointer<vtkDataArray>::Take(vtkDataArray::CreateDataArray(like->GetDataType()));
  out->SetName(like->GetName());
  out->SetNumberOfComponents(like->GetNumberOfComponents());
  Allocate(out, n * like->GetNumberOfComponents());
  return out;
}

// Point-to-point with rank `q` in the global pair order (the lower rank sends first): sends the `n`
// values at `out` and receives `m` values into `in` (no message when a count is 0; both ranks know
// both counts).
template <class T>
void Pair(vtkMultiProcessController* c, int me, int q, const T* out, vtkIdType n, T* in, vtkIdType m,
  int tag)
{
  const auto send = [&] {
    if (n > 0)
    {
      c->Send(out, n, q, tag);
    }
  };
  const auto receive = [&] {
    if (m > 0)
    {
      c->Receive(in, m, q, tag);
    }
  };
  if (me < q)
  {
    send();
    receive();
  }
  else
  {
    receive();
    send();
  }
}
} // namespace

//------------------------------------------------------------------------------
bool Ranks::Swap(int q, const void* out, vtkIdType bytes,
  const std::function<void*(vtkIdType)>& receive, std::string& error)
{
  vtkIdType theirs = 0;
  Pair(this->Controller, this->Me, q, &bytes, 1, &theirs, 1, SizeTag);
  int have = 1;
  void* in = nullptr;
  try
  {
    in = receive(theirs);
  }
  catch (const std::bad_alloc& e)
  {
    error = "out of memory for " + std::to_string(theirs) + " bytes from rank " +
      std::to_string(q) + ": " + OutOfMemoryMessage(e);
    have = 0;
  }
  int theyHave = 0;
  Pair(this->Controller, this->Me, q, &have, 1, &theyHave, 1, SizeTag);
  this->Sent += sizeof(vtkIdType) + sizeof(int);
  if (!have || !theyHave)
  {
    if (have)
    {
      error = "rank " + std::to_string(q) +
        " ran out of memory for the data this rank sends it (see its error)";
    }
    return false;
  }
  Pair(this->Controller, this->Me, q, static_cast<const unsigned char*>(out), bytes,
    static_cast<unsigned char*>(in), theirs, ResponseTag);
  this->Sent += bytes;
  return true;
}

//------------------------------------------------------------------------------
vtkSmartPointer<vtkIdList> IdList(const std::vector<vtkIdType>& ids)
{
  auto list = vtkSmartPointer<vtkIdList>::New();
  list->SetNumberOfIds(static_cast<vtkIdType>(ids.size()));
  std::copy(ids.begin(), ids.end(), list->GetPointer(0));
  return list;
}

vtkSmartPointer<vtkIdList> IdList(vtkIdType first, vtkIdType count)
{
  auto list = vtkSmartPointer<vtkIdList>::New();
  list->SetNumberOfIds(count);
  std::iota(list->GetPointer(0), list->GetPointer(0) + count, first);
  return list;
}

//------------------------------------------------------------------------------
vtkMultiProcessController* Ranks::DistributedController()
{
  vtkMultiProcessController* c = vtkMultiProcessController::GetGlobalController();
  return c && c->GetNumberOfProcesses() > 1 ? c : nullptr;
}

//------------------------------------------------------------------------------
double Pieces::WholeDiagonal() const
{
  double diagonal2 = 0.0;
  for (int axis = 0; axis < 3; ++axis)
  {
    diagonal2 += std::pow(
      (static_cast<double>(this->WholeGrid.dims[axis]) - 1.0) * this->WholeGrid.spacing[axis], 2);
  }
  return std::sqrt(diagonal2);
}

//------------------------------------------------------------------------------
bridge::PointFrame Pieces::Frame() const
{
  bridge::PointFrame frame;
  for (int axis = 0; axis < 3; ++axis)
  {
    frame.origin[axis] = this->Origin[axis];
    frame.first_index[axis] = this->WholeLo[axis];
    frame.spacing[axis] = this->WholeGrid.spacing[axis];
  }
  return frame;
}

//------------------------------------------------------------------------------
Ranks::Ranks(vtkMultiProcessController* controller)
  : Controller(controller)
  , Me(controller->GetLocalProcessId())
  , Count(controller->GetNumberOfProcesses())
{
}

//------------------------------------------------------------------------------
Pieces::Pieces(vtkMultiProcessController* controller, const int wholeExtent[6],
  const int extent[6], const double origin[3], const double spacing[3])
  : Ranks(controller)
{
  std::copy(wholeExtent, wholeExtent + 6, this->WholeExtent);
  std::copy(origin, origin + 3, this->Origin);
  for (int axis = 0; axis < 3; ++axis)
  {
    this->WholeLo[axis] = wholeExtent[2 * axis];
    const int n = wholeExtent[2 * axis + 1] - wholeExtent[2 * axis] + 1;
    this->WholeGrid.dims[axis] = static_cast<std::size_t>(std::max(n, 0));
    this->WholeGrid.origin[axis] = origin[axis] + wholeExtent[2 * axis] * spacing[axis];
    this->WholeGrid.spacing[axis] = spacing[axis];
  }
  vtkIdType own[6];
  for (int i = 0; i < 6; ++i)
  {
    own[i] = extent[i] - this->WholeLo[i / 2];
  }
  std::vector<vtkIdType> all(6 * this->Count);
  this->Controller->AllGather(own, all.data(), 6);
  this->Sent += 6 * sizeof(vtkIdType);
  this->All.assign(all.begin(), all.end());
}

//------------------------------------------------------------------------------
// What Pieces takes from a filter's input and its pipeline information.
struct Pieces::InputGeometry
{
  int Whole[6];
  int Extent[6] = { 0, -1, 0, -1, 0, -1 };
  double Origin[3] = { 0.0, 0.0, 0.0 };
  double Spacing[3] = { 1.0, 1.0, 1.0 };
  InputGeometry(vtkInformation* inInfo, vtkDataSet* input)
  {
    inInfo->Get(vtkStreamingDemandDrivenPipeline::WHOLE_EXTENT(), this->Whole);
    auto* image = vtkImageData::SafeDownCast(input);
    auto* rectilinear = vtkRectilinearGrid::SafeDownCast(input);
    if (input->GetNumberOfPoints() > 0)
    {
      if (image)
      {
        image->GetExtent(this->Extent);
      }
      else if (rectilinear)
      {
        rectilinear->GetExtent(this->Extent);
      }
    }
    if (image)
    {
      image->GetOrigin(this->Origin);
      image->GetSpacing(this->Spacing);
      if (inInfo->Has(vtkDataObject::ORIGIN()) && inInfo->Has(vtkDataObject::SPACING()))
      {
        inInfo->Get(vtkDataObject::ORIGIN(), this->Origin);
        inInfo->Get(vtkDataObject::SPACING(), this->Spacing);
      }
    }
  }
};

Pieces::Pieces(vtkMultiProcessController* controller, vtkInformation* inInfo, vtkDataSet* input)
  : Pieces(controller, InputGeometry(inInfo, input))
{
}

Pieces::Pieces(vtkMultiProcessController* controller, const InputGeometry& g)
  : Pieces(controller, g.Whole, g.Extent, g.Origin, g.Spacing)
{
}

//------------------------------------------------------------------------------
namespace
{
// What GatherWhole puts together: point data, cell data, or a rectilinear grid's coordinates
// along one axis.
enum class Layout
{
  Points,
  Cells,
  AxisX,
  AxisY,
  AxisZ
};

// The tuples of `layout` over extent `e` (VTK order, relative or not): as VTK counts them, so that
// they match the arrays of a piece (a flat piece of a volume has 2-D cells).
vtkIdType TupleCount(Layout layout, const std::int64_t* e)
{
  vtkIdType n[3];
  for (int axis = 0; axis < 3; ++axis)
  {
    n[axis] = std::max<vtkIdType>(e[2 * axis + 1] - e[2 * axis] + 1, 0);
  }
  switch (layout)
  {
    case Layout::Points:
      return n[0] * n[1] * n[2];
    case Layout::Cells:
    {
      if (n[0] * n[1] * n[2] == 0)
      {
        return 0;
      }
      vtkIdType cells = 1;
      for (vtkIdType k : n)
      {
        cells *= k > 1 ? k - 1 : 1;
      }
      return cells;
    }
    default:
      return n[0] * n[1] * n[2] == 0 ? 0 : n[static_cast<int>(layout) - 2];
  }
}

} // namespace

bool Pieces::GatherWhole(vtkDataSet* input, const std::vector<vtkDataArray*>& pointArrays,
  const std::vector<vtkDataArray*>& cellArrays, vtkSmartPointer<vtkDataSet>& whole,
  std::string& error)
{
  whole = nullptr;
  auto* rectilinear = vtkRectilinearGrid::SafeDownCast(input);
  const bool empty = this->OwnExtent()[1] < this->OwnExtent()[0] ||
    this->OwnExtent()[3] < this->OwnExtent()[2] || this->OwnExtent()[5] < this->OwnExtent()[4];
  // What this rank sends, in order: point arrays, cell arrays, then a rectilinear grid's
  // coordinates (none on an empty piece).
  std::vector<std::pair<vtkDataArray*, Layout>> mine;
  if (!empty)
  {
    for (vtkDataArray* a : pointArrays)
    {
      mine.emplace_back(a, Layout::Points);
    }
    for (vtkDataArray* a : cellArrays)
    {
      mine.emplace_back(a, Layout::Cells);
    }
    if (rectilinear)
    {
      mine.emplace_back(rectilinear->GetXCoordinates(), Layout::AxisX);
      mine.emplace_back(rectilinear->GetYCoordinates(), Layout::AxisY);
      mine.emplace_back(rectilinear->GetZCoordinates(), Layout::AxisZ);
    }
  }
  // Every rank's kinds of arrays: layout, type and components of each (type -1: an array that
  // does not have the piece's number of tuples).
  std::vector<std::int32_t> schema;
  for (const auto& [a, layout] : mine)
  {
    const bool fits = a && a->GetNumberOfTuples() == TupleCount(layout, this->OwnExtent().data());
    schema.insert(schema.end(),
      { static_cast<std::int32_t>(layout), fits ? a->GetDataType() : -1,
        a ? a->GetNumberOfComponents() : 0 });
  }
  const std::vector<double> lengths = this->PerRank(static_cast<double>(schema.size()));
  std::vector<std::int32_t> schemas;
  if (!this->Concatenate(schema, schemas, error))
  {
    return false;
  }
  bool ok = true;
  try
  {
    bridge::piece_check_cover(this->WholeGrid, this->Extents());
  }
  catch (const rust::Error& e)
  {
    error = e.what();
    ok = false;
  }
  // The first rank with a piece describes the arrays; the others must hold the same kinds.
  int first = -1;
  std::size_t start = 0;
  std::vector<std::size_t> starts(this->Count);
  for (int r = 0; r < this->Count; ++r)
  {
    starts[r] = start;
    start += static_cast<std::size_t>(lengths[r]);
    const std::int64_t* e = this->All.data() + 6 * r;
    if (first < 0 && e[1] >= e[0] && e[3] >= e[2] && e[5] >= e[4])
    {
      first = r;
    }
  }
  if (first < 0)
  {
    return ok; // no rank has a piece: nothing to put together
  }
  const std::size_t n = static_cast<std::size_t>(lengths[first]);
  for (int r = 0; r < this->Count && ok; ++r)
  {
    const std::int64_t* e = this->All.data() + 6 * r;
    if (e[1] < e[0] || e[3] < e[2] || e[5] < e[4])
    {
      continue;
    }
    const bool same = static_cast<std::size_t>(lengths[r]) == n &&
      std::equal(schemas.begin() + starts[r], schemas.begin() + starts[r] + n,
        schemas.begin() + starts[first]);
    bool fits = true;
    for (std::size_t k = 1; k < static_cast<std::size_t>(lengths[r]); k += 3)
    {
      fits = fits && schemas[starts[r] + k] >= 0;
    }
    if (!same || !fits)
    {
      error = "rank " + std::to_string(r) +
        (fits ? " holds other arrays than rank " + std::to_string(first)
              : " holds an array whose size is not its piece's");
      ok = false;
    }
  }
  if (!ok)
  {
    return false; // decided alike on every rank from what all ranks sent
  }

  // One all-gather per array: each rank's piece as raw bytes, placed by its extent.
  const int* we = this->WholeExtent;
  const std::int64_t wholeRel[6] = { 0, we[1] - we[0], 0, we[3] - we[2], 0, we[5] - we[4] };
  std::vector<vtkSmartPointer<vtkDataArray>> assembled;
  for (std::size_t k = 0; k < n / 3; ++k)
  {
    const std::int32_t* kind = schemas.data() + starts[first] + 3 * k;
    const Layout layout = static_cast<Layout>(kind[0]);
    vtkSmartPointer<vtkDataArray> out =
      vtkSmartPointer<vtkDataArray>::Take(vtkDataArray::CreateDataArray(kind[1]));
    const vtkIdType tupleBytes = kind[2] * out->GetDataTypeSize();
    std::vector<vtkIdType> counts(this->Count);
    std::vector<vtkIdType> offsets(this->Count, 0);
    vtkIdType total = 0;
    for (int r = 0; r < this->Count; ++r)
    {
      counts[r] = 3 * k < static_cast<std::size_t>(lengths[r])
        ? TupleCount(layout, this->All.data() + 6 * r) * tupleBytes
        : 0;
      offsets[r] = total;
      total += counts[r];
    }
    if (total > std::numeric_limits<int>::max())
    {
      error = "an array of the whole image has " + std::to_string(total) +
        " bytes, more than an MPI all-gather takes (2 GiB)";
      return false; // decided alike on every rank
    }
    // Every buffer of this array is allocated before its all-gather, and agreed on.
    vtkSmartPointer<vtkDataArray> send;
    std::vector<unsigned char> received;
    const auto allocate = [&] {
      send = empty ? nullptr : Contiguous(mine[k].first);
      received.resize(static_cast<std::size_t>(total));
      if (!empty)
      {
        out->SetName(mine[k].first->GetName());
        out->SetNumberOfComponents(kind[2]);
        Allocate(out, TupleCount(layout, wholeRel) * kind[2]);
      }
    };
    if (!this->Allocated(allocate,
          "an array of the whole image (" + std::to_string(total) + " bytes to receive)", error))
    {
      return false;
    }
    {
      Clock clock{ this->Seconds };
      this->Controller->AllGatherV(
        send ? static_cast<unsigned char*>(send->GetVoidPointer(0)) : nullptr, received.data(),
        counts[this->Me], counts.data(), offsets.data());
    }
    this->Sent += counts[this->Me];
    if (empty)
    {
      continue;
    }
    auto* target = static_cast<unsigned char*>(out->GetVoidPointer(0));
    for (int r = 0; r < this->Count; ++r)
    {
      const std::int64_t* e = this->All.data() + 6 * r;
      const unsigned char* source = received.data() + offsets[r];
      if (counts[r] == 0)
      {
        continue;
      }
      if (layout >= Layout::AxisX)
      {
        const int axis = static_cast<int>(layout) - 2;
        std::copy(source, source + counts[r], target + e[2 * axis] * tupleBytes);
        continue;
      }
      // Rows along x, over the points or (3-D) cells of the piece; a piece flat along an axis
      // where the whole is not has no cells of the whole.
      const vtkIdType c = layout == Layout::Cells ? 1 : 0;
      std::int64_t hi[3];
      vtkIdType dims[3];
      bool flat = false;
      for (int axis = 0; axis < 3; ++axis)
      {
        const std::int64_t wholeCount = wholeRel[2 * axis + 1] + 1;
        const vtkIdType cellCount = wholeCount > 1 ? wholeCount - 1 : 1;
        dims[axis] = c ? cellCount : wholeCount;
        hi[axis] = e[2 * axis + 1] - (c && wholeCount > 1 ? 1 : 0);
        flat = flat || hi[axis] < e[2 * axis];
      }
      if (flat)
      {
        continue;
      }
      const vtkIdType rowBytes = (hi[0] - e[0] + 1) * tupleBytes;
      for (std::int64_t z = e[4]; z <= hi[2]; ++z)
      {
        for (std::int64_t y = e[2]; y <= hi[1]; ++y, source += rowBytes)
        {
          std::copy(source, source + rowBytes,
            target + (e[0] + dims[0] * (y + dims[1] * z)) * tupleBytes);
        }
      }
    }
    assembled.push_back(out);
  }
  if (empty)
  {
    return true;
  }

  // The whole dataset, with the input's geometry so that positions are computed as for the input.
  if (rectilinear)
  {
    auto grid = vtkSmartPointer<vtkRectilinearGrid>::New();
    grid->SetExtent(this->WholeExtent);
    const std::size_t c = assembled.size() - 3;
    grid->SetXCoordinates(assembled[c]);
    grid->SetYCoordinates(assembled[c + 1]);
    grid->SetZCoordinates(assembled[c + 2]);
    assembled.resize(c);
    whole = grid;
  }
  else
  {
    auto image = vtkSmartPointer<vtkImageData>::New();
    image->SetExtent(this->WholeExtent);
    image->SetOrigin(this->Origin);
    image->SetSpacing(this->WholeGrid.spacing.data());
    whole = image;
  }
  for (std::size_t k = 0; k < assembled.size(); ++k)
  {
    if (k < pointArrays.size())
    {
      whole->GetPointData()->AddArray(assembled[k]);
    }
    else
    {
      whole->GetCellData()->AddArray(assembled[k]);
    }
  }
  if (!pointArrays.empty())
  {
    whole->GetPointData()->SetScalars(assembled[0]);
  }
  return true;
}

//------------------------------------------------------------------------------
void Ranks::AddFigures(vtkFieldData* fieldData, const char* cellsName, vtkIdType cells,
  std::chrono::steady_clock::time_point started)
{
  const double seconds =
    std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
  struct rusage usage;
  getrusage(RUSAGE_SELF, &usage);
  const std::vector<double> cellsPerRank = this->PerRank(static_cast<double>(cells));
  const std::vector<double> secondsPerRank = this->PerRank(seconds);
  const std::vector<double> bytesPerRank = this->PerRank(this->BytesSent());
  const std::vector<double> exchangePerRank = this->PerRank(this->ExchangeSeconds());
  const std::vector<double> peakPerRank = this->PerRank(usage.ru_maxrss * 1024.0);
  for (const auto& [name, values] : { std::make_pair(cellsName, &cellsPerRank),
         std::make_pair("SecondsPerRank", &secondsPerRank),
         std::make_pair("BytesSentPerRank", &bytesPerRank),
         std::make_pair("ExchangeSecondsPerRank", &exchangePerRank),
         std::make_pair("PeakMemoryPerRank", &peakPerRank) })
  {
    fieldData->AddArray(
      NamedArray<vtkDoubleArray>(name, static_cast<vtkIdType>(values->size()), values->data()));
  }
}

//------------------------------------------------------------------------------
void Ranks::ReportCaught(vtkAlgorithm* filter, const char* name, const char* failure)
{
  try
  {
    throw;
  }
  catch (const std::bad_alloc& e)
  {
    ReportOutOfMemory(filter, name, e);
  }
  catch (const std::exception& e) // rust::Error among them
  {
    vtkErrorWithObjectMacro(filter, << name << " " << failure << ": " << e.what());
  }
  catch (...)
  {
    vtkErrorWithObjectMacro(filter, << name << " " << failure << ": unknown error.");
  }
}

//------------------------------------------------------------------------------
bool Ranks::AllOk(bool ok)
{
  Clock clock{ this->Seconds };
  const int mine = ok ? 1 : 0;
  int all = 0;
  this->Controller->AllReduce(&mine, &all, 1, vtkCommunicator::MIN_OP);
  this->Sent += sizeof(int);
  return all == 1;
}

namespace
{
// What a rank says at Agree and Share; the maximum over the ranks decides. A failure or an abort
// outweighs a shared step: the ranks sharing it stop.
enum AgreeCode : int
{
  Done = 0,
  Sharing = 1, // in a shared step (Share)
  FailedHere = 2,
  AbortedHere = 3, // CheckAbort sets AbortOutput; the executive sets it too when an input arrived ABORTED
};
} // namespace

bool Ranks::Agree(vtkAlgorithm* filter, const char* name, bool ok, const char* what)
{
  if (this->StoppedInStep)
  {
    // A Share agreed on it with every rank already.
    this->StoppedInStep = false;
    return false;
  }
  for (;;)
  {
    const bool aborted = filter->CheckAbort() || filter->GetAbortOutput();
    const int mine = aborted ? AbortedHere : ok ? Done : FailedHere;
    int all = Done;
    {
      Clock clock{ this->Seconds };
      this->Controller->AllReduce(&mine, &all, 1, vtkCommunicator::MAX_OP);
      this->Sent += sizeof(int);
    }
    if (all == Done)
    {
      return true;
    }
    if (all == Sharing)
    {
      // Other ranks share a step: take part in their exchange with nothing, then agree again.
      std::vector<unsigned char> none;
      std::vector<vtkIdType> lengths;
      std::string error;
      if (this->ConcatenateValues<unsigned char>(nullptr, 0, none, lengths, error))
      {
        continue;
      }
      vtkErrorWithObjectMacro(filter, << name << " stopped: " << error);
      return false;
    }
    if (all == AbortedHere)
    {
      // Every rank ends this execution as an aborted one: its outputs are emptied and marked
      // ABORTED on every rank alike, so a later request for any port executes the filter on every
      // rank, never on the aborting rank alone.
      this->Aborted = true;
      filter->SetAbortOutput(true);
    }
    else if (ok)
    {
      vtkErrorWithObjectMacro(
        filter, << name << " stopped: " << what << " failed on another rank (see its error).");
    }
    return false;
  }
}

bool Ranks::Share(vtkAlgorithm* filter, const char* name, const unsigned char* bytes,
  std::size_t size, std::vector<unsigned char>& all, std::vector<vtkIdType>& lengths)
{
  const bool aborted = filter->CheckAbort() || filter->GetAbortOutput();
  const int mine = aborted ? AbortedHere : Sharing;
  int code = Done;
  {
    Clock clock{ this->Seconds };
    this->Controller->AllReduce(&mine, &code, 1, vtkCommunicator::MAX_OP);
    this->Sent += sizeof(int);
  }
  if (code == Sharing)
  {
    std::string error;
    if (this->ConcatenateValues(bytes, static_cast<vtkIdType>(size), all, lengths, error))
    {
      return true;
    }
    vtkErrorWithObjectMacro(filter, << name << " stopped: " << error);
  }
  else if (code == AbortedHere)
  {
    this->Aborted = true;
    filter->SetAbortOutput(true);
  }
  else
  {
    vtkErrorWithObjectMacro(
      filter, << name << " stopped: the computation failed on another rank (see its error).");
  }
  this->StoppedInStep = true;
  return false;
}

bool SharedStep::all_gather(rust::Slice<const std::uint8_t> bytes, rust::Vec<std::uint8_t>& all,
  rust::Vec<std::uint64_t>& lengths) noexcept
{
  try
  {
    std::vector<unsigned char> gathered;
    std::vector<vtkIdType> sizes;
    if (!this->RanksOfStep.Share(
          this->Filter, this->Name, bytes.data(), bytes.size(), gathered, sizes))
    {
      return false;
    }
    all.reserve(gathered.size());
    for (unsigned char b : gathered)
    {
      all.push_back(b);
    }
    for (vtkIdType n : sizes)
    {
      lengths.push_back(static_cast<std::uint64_t>(n));
    }
    return true;
  }
  catch (...)
  {
    // Out of memory copying what every rank sent: the other ranks went on; this one stops at
    // its next Agree with its error.
    Ranks::ReportCaught(this->Filter, this->Name, "could not take what the other ranks sent");
    return false;
  }
}

bool Ranks::Allocated(
  const std::function<void()>& allocate, const std::string& what, std::string& error)
{
  bool allocated = true;
  try
  {
    allocate();
  }
  catch (const std::bad_alloc& e)
  {
    error = "out of memory for " + what + ": " + OutOfMemoryMessage(e);
    allocated = false;
  }
  if (this->AllOk(allocated))
  {
    return true;
  }
  if (allocated)
  {
    error = "another rank ran out of memory for " + what + " (see its error)";
  }
  return false;
}

bool Ranks::MaxInPlace(std::vector<double>& values, std::string& error)
{
  std::vector<double> out;
  if (!this->Allocated([&] { out.resize(values.size()); },
        "the maxima over the ranks (" + std::to_string(values.size()) + " values)", error))
  {
    return false;
  }
  Clock clock{ this->Seconds };
  this->Controller->AllReduce(values.data(), out.data(),
    static_cast<vtkIdType>(values.size()), vtkCommunicator::MAX_OP);
  this->Sent += values.size() * sizeof(double);
  values.swap(out);
  return true;
}

vtkIdType Ranks::Sum(vtkIdType value)
{
  Clock clock{ this->Seconds };
  vtkIdType out = 0;
  this->Controller->AllReduce(&value, &out, 1, vtkCommunicator::SUM_OP);
  this->Sent += sizeof(vtkIdType);
  return out;
}

bool Ranks::Concatenate(
  const std::vector<std::int32_t>& values, std::vector<std::int32_t>& all, std::string& error)
{
  static_assert(std::is_same_v<std::int32_t, int>, "vtkCommunicator exchanges int");
  std::vector<vtkIdType> lengths;
  return this->ConcatenateValues(
    values.data(), static_cast<vtkIdType>(values.size()), all, lengths, error);
}

template <class T>
bool Ranks::ConcatenateValues(const T* values, vtkIdType count, std::vector<T>& all,
  std::vector<vtkIdType>& lengths, std::string& error)
{
  lengths.assign(this->Count, 0);
  {
    Clock clock{ this->Seconds };
    this->Controller->AllGather(&count, lengths.data(), 1);
  }
  std::vector<vtkIdType> offsets(this->Count, 0);
  for (int r = 1; r < this->Count; ++r)
  {
    offsets[r] = offsets[r - 1] + lengths[r - 1];
  }
  const vtkIdType total = offsets.back() + lengths.back();
  if (!this->Allocated([&] { all.resize(static_cast<std::size_t>(total)); },
        "the values of every rank (" + std::to_string(total) + ")", error))
  {
    return false;
  }
  Clock clock{ this->Seconds };
  this->Controller->AllGatherV(values, all.data(), count, lengths.data(), offsets.data());
  this->Sent += sizeof(vtkIdType) + count * sizeof(T);
  return true;
}

bool Ranks::ExchangeBytes(rust::Slice<const std::size_t> counts, std::size_t size,
  const void* values, const std::function<void*(vtkIdType)>& receive, bool& moved,
  std::string& error)
{
  Clock clock{ this->Seconds };
  bool ok = counts.size() == static_cast<std::size_t>(this->Count);
  if (!ok)
  {
    // Send nothing, but take part in the exchange: the other ranks wait for it.
    error = std::to_string(counts.size()) + " lists to send for " + std::to_string(this->Count) +
      " ranks";
  }
  // Who sends to whom: row p holds a bit per rank q that p has a list for.
  const std::size_t row = (static_cast<std::size_t>(this->Count) + 7) / 8;
  std::vector<unsigned char> mine(row, 0);
  for (int q = 0; q < this->Count && ok; ++q)
  {
    if (q != this->Me && counts[q] > 0)
    {
      mine[q / 8] |= static_cast<unsigned char>(1u << (q % 8));
    }
  }
  std::vector<unsigned char> all(row * this->Count);
  this->Controller->AllGather(mine.data(), all.data(), static_cast<vtkIdType>(row));
  this->Sent += row;
  const auto sends = [&](int p, int q) { return (all[p * row + q / 8] >> (q % 8)) & 1u; };
  moved = std::any_of(all.begin(), all.end(), [](unsigned char b) { return b != 0; });
  const auto* bytes = static_cast<const unsigned char*>(values);
  std::size_t offset = 0;
  for (int q = 0; q < this->Count; ++q)
  {
    const std::size_t n = ok ? counts[q] * size : 0;
    if (q != this->Me && (sends(this->Me, q) || sends(q, this->Me)))
    {
      std::string swapError;
      const bool swapped =
        this->Swap(q, bytes + offset, static_cast<vtkIdType>(n), receive, swapError);
      if (!swapped && ok)
      {
        error = swapError;
        ok = false;
      }
    }
    offset += n;
  }
  return ok;
}

std::vector<double> Ranks::PerRank(double value)
{
  Clock clock{ this->Seconds };
  std::vector<double> out(this->Count);
  this->Controller->AllGather(&value, out.data(), 1);
  this->Sent += sizeof(double);
  return out;
}

//------------------------------------------------------------------------------
bool Pieces::Fetch(rust::Slice<const std::uint64_t> ids, const std::vector<vtkDataArray*>& arrays,
  std::vector<vtkSmartPointer<vtkDataArray>>& fetched, std::string& error)
{
  Clock clock{ this->Seconds };
  fetched.clear();
  const vtkIdType n = static_cast<vtkIdType>(ids.size());
  // Which rank holds each point; what to ask each rank for, and where the answers go.
  bool ok = true;
  std::vector<std::vector<std::uint64_t>> want(this->Count);
  std::vector<std::vector<vtkIdType>> slots(this->Count);
  try
  {
    for (vtkDataArray* a : arrays)
    {
      fetched.push_back(SameKind(a, n));
    }
    const rust::Vec<std::uint32_t> owners =
      bridge::piece_point_owners(this->WholeGrid, this->Extents(), ids);
    for (vtkIdType k = 0; k < n; ++k)
    {
      const std::uint32_t o = owners[k];
      if (static_cast<int>(o) >= this->Count || static_cast<int>(o) == this->Me)
      {
        error = "point " + std::to_string(ids[k]) + " of the whole image is held by no other rank";
        ok = false;
        break;
      }
      want[o].push_back(ids[k]);
      slots[o].push_back(k);
    }
  }
  catch (const rust::Error& e)
  {
    error = e.what();
    ok = false;
  }
  catch (const std::bad_alloc& e)
  {
    error = "out of memory for the points to fetch: " + OutOfMemoryMessage(e);
    ok = false;
  }
  std::vector<std::size_t> tuples(this->Count, 0);
  for (int q = 0; q < this->Count && ok; ++q)
  {
    tuples[q] = want[q].size();
  }
  return this->Ask(
    want, tuples,
    [&](const std::vector<std::uint64_t>& asked) {
      return bridge::piece_local_ids(
        this->WholeGrid, this->OwnExtent(), { asked.data(), asked.size() });
    },
    [&](int q, std::size_t m, vtkDataArray* incoming) {
      fetched[m]->InsertTuples(
        IdList(slots[q]), IdList(0, incoming->GetNumberOfTuples()), incoming);
    },
    arrays, ok, error);
}

//------------------------------------------------------------------------------
bool Pieces::SourceTable(vtkAlgorithm* filter, const char* name,
  const bridge::PointSources* sources, vtkPointData* in, vtkDataArray* skip, vtkPointData* table)
{
  const char* failure = "could not fetch point data from other ranks";
  return Run(filter, name, failure, [&] {
    std::vector<vtkDataArray*> arrays;
    for (int i = 0; in && i < in->GetNumberOfArrays(); ++i)
    {
      vtkDataArray* a = in->GetArray(i);
      if (a && a != skip &&
        std::string(a->GetName() ? a->GetName() : "") != vtkDataSetAttributes::GhostArrayName())
      {
        arrays.push_back(a);
      }
    }
    const rust::Slice<const std::uint64_t> remote =
      sources ? sources->remote() : rust::Slice<const std::uint64_t>();
    std::vector<vtkSmartPointer<vtkDataArray>> fetched;
    std::string error;
    if (!this->Fetch(remote, arrays, fetched, error))
    {
      vtkErrorWithObjectMacro(filter, << name << " " << failure << ": " << error);
      return false;
    }
    if (!sources)
    {
      return true;
    }
    const rust::Slice<const std::uint64_t> local = sources->local();
    const vtkIdType own = static_cast<vtkIdType>(local.size());
    const vtkIdType other = static_cast<vtkIdType>(remote.size());
    auto held = vtkSmartPointer<vtkIdList>::New();
    held->SetNumberOfIds(own);
    std::copy(local.begin(), local.end(), held->GetPointer(0));
    for (std::size_t m = 0; m < arrays.size(); ++m)
    {
      vtkSmartPointer<vtkDataArray> rows = SameKind(arrays[m], own + other);
      rows->InsertTuples(IdList(0, own), held, arrays[m]);
      rows->InsertTuples(IdList(own, other), IdList(0, other), fetched[m]);
      fetched[m] = nullptr;
      const int at = table->AddArray(rows);
      for (int role = 0; role < vtkDataSetAttributes::NUM_ATTRIBUTES; ++role)
      {
        if (in->GetAttribute(role) == arrays[m])
        {
          table->SetActiveAttribute(at, role);
        }
      }
    }
    return true;
  });
}

//------------------------------------------------------------------------------
bool Pieces::FetchBoxes(const bridge::SampleRequests& requests,
  const std::vector<vtkDataArray*>& arrays, std::vector<vtkSmartPointer<vtkDataArray>>& fetched,
  std::string& error)
{
  Clock clock{ this->Seconds };
  fetched.clear();
  // The words (seven per box) to send each rank, how many tuples it answers, and where they go:
  // rank after rank.
  bool ok = requests.counts.size() == static_cast<std::size_t>(this->Count) &&
    requests.points.size() == requests.counts.size() && requests.counts[this->Me] == 0;
  if (!ok)
  {
    error = "the samples to fetch are not asked of the other ranks";
  }
  std::vector<std::vector<std::uint64_t>> want(this->Count);
  std::vector<std::size_t> tuples(this->Count, 0);
  std::vector<vtkIdType> offsets(this->Count, 0);
  try
  {
    std::size_t words = 0;
    vtkIdType total = 0;
    for (int q = 0; q < this->Count && ok; ++q)
    {
      const std::size_t n = 7 * requests.counts[q];
      if (words + n > requests.boxes.size())
      {
        error = "fewer boxes to ask for than counted";
        ok = false;
        break;
      }
      want[q].assign(requests.boxes.begin() + words, requests.boxes.begin() + words + n);
      words += n;
      tuples[q] = requests.points[q];
      offsets[q] = total;
      total += static_cast<vtkIdType>(tuples[q]);
    }
    for (vtkDataArray* a : arrays)
    {
      fetched.push_back(SameKind(a, ok ? total : 0));
    }
  }
  catch (const std::bad_alloc& e)
  {
    error = "out of memory for the samples to fetch: " + OutOfMemoryMessage(e);
    ok = false;
  }
  if (!ok)
  {
    std::fill(tuples.begin(), tuples.end(), 0);
    for (auto& w : want)
    {
      w.clear();
    }
  }
  return this->Ask(
    want, tuples,
    [&](const std::vector<std::uint64_t>& asked) {
      return bridge::piece_box_local_ids(
        this->WholeGrid, this->OwnExtent(), { asked.data(), asked.size() });
    },
    [&](int q, std::size_t m, vtkDataArray* incoming) {
      fetched[m]->InsertTuples(offsets[q], incoming->GetNumberOfTuples(), 0, incoming);
    },
    arrays, ok, error);
}

//------------------------------------------------------------------------------
bool Pieces::Ask(std::vector<std::vector<std::uint64_t>>& want,
  const std::vector<std::size_t>& tuples,
  const std::function<rust::Vec<std::int64_t>(const std::vector<std::uint64_t>&)>& held,
  const std::function<void(int, std::size_t, vtkDataArray*)>& place,
  const std::vector<vtkDataArray*>& arrays, bool ok, std::string& error)
{
  // The first failure is the one reported (later ones follow from it).
  const auto fail = [&](const std::string& what) {
    if (ok)
    {
      error = what;
    }
    ok = false;
  };
  if (!ok)
  {
    // Ask for nothing, but take part in the exchange: the other ranks wait for it.
    for (auto& w : want)
    {
      w.clear();
    }
  }

  std::string swapError;
  // Requests: this rank's number of arrays, then the words it sends each rank. How many words
  // each rank sends is known even when they could not be received: the messages of the
  // responses depend on it alone, so that both ranks of a pair exchange as many.
  std::vector<std::vector<std::uint64_t>> asked(this->Count);
  std::vector<std::size_t> askedCount(this->Count, 0);
  std::vector<vtkIdType> theirArrays(this->Count, 0);
  for (int q = 0; q < this->Count; ++q)
  {
    if (q == this->Me)
    {
      continue;
    }
    const vtkIdType mine = static_cast<vtkIdType>(arrays.size());
    Pair(this->Controller, this->Me, q, &mine, 1, &theirArrays[q], 1, RequestTag);
    this->Sent += sizeof(vtkIdType);
    const bool moved = this->Swap(
      q, want[q].data(), static_cast<vtkIdType>(want[q].size() * sizeof(std::uint64_t)),
      [&](vtkIdType bytes) {
        askedCount[q] = static_cast<std::size_t>(bytes) / sizeof(std::uint64_t);
        asked[q].resize(askedCount[q]);
        return static_cast<void*>(asked[q].data());
      },
      swapError);
    if (!moved)
    {
      asked[q].clear(); // not received: answered with no tuples
      fail(swapError);
    }
  }

  // Responses: one message per array of the responding rank.
  for (int q = 0; q < this->Count; ++q)
  {
    if (q == this->Me)
    {
      continue;
    }
    // What q asked for, from this rank's arrays (an answer of no tuples, refused by q, when this
    // rank does not hold every point asked for or could not make the answer).
    std::vector<vtkSmartPointer<vtkDataArray>> answers;
    try
    {
      vtkNew<vtkIdList> local;
      if (!asked[q].empty())
      {
        const rust::Vec<std::int64_t> ids = held(asked[q]);
        if (std::find(ids.begin(), ids.end(), -1) == ids.end())
        {
          local->SetNumberOfIds(static_cast<vtkIdType>(ids.size()));
          std::copy(ids.begin(), ids.end(), local->GetPointer(0));
        }
      }
      for (vtkDataArray* a : arrays)
      {
        auto answer = SameKind(a, local->GetNumberOfIds());
        if (local->GetNumberOfIds() > 0)
        {
          a->GetTuples(local, answer);
        }
        answers.push_back(answer);
      }
    }
    catch (const rust::Error& e)
    {
      fail(e.what());
    }
    catch (const std::bad_alloc& e)
    {
      fail("out of memory for the points asked for: " + OutOfMemoryMessage(e));
    }
    for (std::size_t m = answers.size(); m < arrays.size(); ++m)
    {
      answers.push_back(SameKind(arrays[m], 0));
    }
    // Arrays go only where points were asked for, as many as both ranks hold (non-empty pieces
    // of one image hold the same point arrays; a difference is an error below).
    const std::size_t common = std::min(arrays.size(), static_cast<std::size_t>(theirArrays[q]));
    const std::size_t toSend = askedCount[q] == 0 ? 0 : common;
    const std::size_t toReceive = want[q].empty() ? 0 : common;
    if (!want[q].empty() && theirArrays[q] != static_cast<vtkIdType>(arrays.size()))
    {
      fail("rank " + std::to_string(q) + " holds other point arrays than this rank");
    }
    for (std::size_t m = 0; m < std::max(toSend, toReceive); ++m)
    {
      vtkDataArray* answer = m < toSend ? answers[m].GetPointer() : nullptr;
      vtkSmartPointer<vtkDataArray> incoming;
      const bool moved = this->Swap(q, answer ? answer->GetVoidPointer(0) : nullptr,
        answer ? answer->GetNumberOfValues() * answer->GetDataTypeSize() : 0,
        [&](vtkIdType bytes) -> void* {
          if (m >= toReceive)
          {
            return nullptr;
          }
          const vtkIdType tupleBytes =
            arrays[m]->GetNumberOfComponents() * arrays[m]->GetDataTypeSize();
          incoming = SameKind(arrays[m], tupleBytes > 0 ? bytes / tupleBytes : 0);
          return incoming->GetVoidPointer(0);
        },
        swapError);
      if (!moved)
      {
        fail(swapError);
      }
      if (!moved || m >= toReceive)
      {
        continue;
      }
      if (incoming->GetNumberOfTuples() != static_cast<vtkIdType>(tuples[q]))
      {
        fail("rank " + std::to_string(q) + " answered with other arrays or points than asked");
        continue;
      }
      place(q, m, incoming);
    }
  }
  return ok;
}

//------------------------------------------------------------------------------
WholeImage::Key WholeImage::KeyOf(const Pieces& pieces, vtkImageData* input, vtkDataArray* processed)
{
  Key key;
  key.Input = InputKey(input, processed);
  key.Extents.assign(pieces.Extents().begin(), pieces.Extents().end());
  return key;
}

//------------------------------------------------------------------------------
bool WholeImage::Stale(Pieces& pieces, const Key& key) const
{
  return pieces.Sum(this->Built == key ? 0 : 1) > 0;
}

//------------------------------------------------------------------------------
bool WholeImage::Gather(vtkAlgorithm* filter, const char* name, Pieces& pieces,
  vtkImageData* input, vtkDataArray* samples, const Key& key)
{
  this->Image = nullptr;
  this->Built = Key();
  std::string error;
  vtkSmartPointer<vtkDataSet> gathered;
  std::vector<vtkDataArray*> pointArrays;
  if (samples)
  {
    pointArrays.push_back(samples);
  }
  const bool ok = pieces.GatherWhole(input, pointArrays, {}, gathered, error);
  if (!ok)
  {
    vtkErrorWithObjectMacro(
      filter, << name << " could not fetch the image from the other ranks: " << error);
  }
  if (!pieces.Agree(filter, name, ok, "fetching the image"))
  {
    return false;
  }
  this->Image = vtkImageData::SafeDownCast(gathered);
  this->Built = key;
  return true;
}

//------------------------------------------------------------------------------
vtkImageData* WholeImage::Get() const
{
  return this->Image;
}

} // namespace vtkDiamonds
