#include "vtkDiamondsPieces.h"

#include "vtkAlgorithm.h"
#include "vtkCommunicator.h"
#include "vtkDataArray.h"
#include "vtkIdList.h"
#include "vtkImageData.h"
#include "vtkInformation.h"
#include "vtkMultiProcessController.h"
#include "vtkPointData.h"
#include "vtkStreamingDemandDrivenPipeline.h"
#include "vtkNew.h"
#include "vtkTypeInt64Array.h"
#include "vtkTypeUInt64Array.h"

#include <algorithm>
#include <chrono>
#include <numeric>

namespace vtkDiamonds
{
namespace
{
// Message tags of the point fetch (requests, then one response per array).
constexpr int RequestTag = 0x4449; // "DI"
constexpr int ResponseTag = 0x4450;

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

// An array of `n` tuples of `like`'s type, components and name.
vtkSmartPointer<vtkDataArray> SameKind(vtkDataArray* like, vtkIdType n)
{
  auto out = vtkSmartPointer<vtkDataArray>::Take(like->NewInstance());
  out->SetName(like->GetName());
  out->SetNumberOfComponents(like->GetNumberOfComponents());
  out->SetNumberOfTuples(n);
  return out;
}
} // namespace

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
vtkMultiProcessController* Pieces::DistributedController()
{
  vtkMultiProcessController* c = vtkMultiProcessController::GetGlobalController();
  return c && c->GetNumberOfProcesses() > 1 ? c : nullptr;
}

//------------------------------------------------------------------------------
Pieces::Pieces(vtkMultiProcessController* controller, const int wholeExtent[6],
  const int extent[6], const double origin[3], const double spacing[3])
  : Controller(controller)
  , Me(controller->GetLocalProcessId())
  , Ranks(controller->GetNumberOfProcesses())
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
  std::vector<vtkIdType> all(6 * this->Ranks);
  this->Controller->AllGather(own, all.data(), 6);
  this->Sent += 6 * sizeof(vtkIdType);
  this->All.assign(all.begin(), all.end());
}

//------------------------------------------------------------------------------
// What Pieces takes from a filter's input image and its pipeline information.
struct Pieces::InputGeometry
{
  int Whole[6];
  int Extent[6] = { 0, -1, 0, -1, 0, -1 };
  double Origin[3];
  double Spacing[3];
  InputGeometry(vtkInformation* inInfo, vtkImageData* input)
  {
    inInfo->Get(vtkStreamingDemandDrivenPipeline::WHOLE_EXTENT(), this->Whole);
    if (input->GetNumberOfPoints() > 0)
    {
      input->GetExtent(this->Extent);
    }
    input->GetOrigin(this->Origin);
    input->GetSpacing(this->Spacing);
    if (inInfo->Has(vtkDataObject::ORIGIN()) && inInfo->Has(vtkDataObject::SPACING()))
    {
      inInfo->Get(vtkDataObject::ORIGIN(), this->Origin);
      inInfo->Get(vtkDataObject::SPACING(), this->Spacing);
    }
  }
};

Pieces::Pieces(vtkMultiProcessController* controller, vtkInformation* inInfo, vtkImageData* input)
  : Pieces(controller, InputGeometry(inInfo, input))
{
}

Pieces::Pieces(vtkMultiProcessController* controller, const InputGeometry& g)
  : Pieces(controller, g.Whole, g.Extent, g.Origin, g.Spacing)
{
}

//------------------------------------------------------------------------------
bool Pieces::GatherWhole(
  vtkDataArray* samples, vtkSmartPointer<vtkImageData>& whole, std::string& error)
{
  whole = nullptr;
  std::vector<vtkDataArray*> arrays;
  if (samples)
  {
    arrays.push_back(samples);
  }
  rust::Vec<std::uint64_t> others;
  bool ok = true;
  try
  {
    others = bridge::piece_other_points(this->WholeGrid, this->OwnExtent());
  }
  catch (const rust::Error& e)
  {
    error = e.what();
    ok = false;
  }
  std::vector<vtkSmartPointer<vtkDataArray>> fetched;
  ok = this->Fetch({ others.data(), others.size() }, arrays, fetched, error) && ok;
  if (!ok || !samples)
  {
    return ok;
  }
  const std::size_t* dims = this->WholeGrid.dims.data();
  const vtkIdType nx = static_cast<vtkIdType>(dims[0]);
  const vtkIdType ny = static_cast<vtkIdType>(dims[1]);
  vtkSmartPointer<vtkDataArray> all = SameKind(samples, nx * ny * static_cast<vtkIdType>(dims[2]));
  // This rank's rows, then the fetched points (listed in `others` order).
  const std::int64_t* e = this->All.data() + 6 * this->Me;
  const vtkIdType rowLength = e[1] - e[0] + 1;
  vtkIdType source = 0;
  for (std::int64_t z = e[4]; z <= e[5]; ++z)
  {
    for (std::int64_t y = e[2]; y <= e[3]; ++y, source += rowLength)
    {
      all->InsertTuples(e[0] + nx * (y + ny * z), rowLength, source, samples);
    }
  }
  for (std::size_t k = 0; k < others.size(); ++k)
  {
    all->SetTuple(static_cast<vtkIdType>(others[k]), static_cast<vtkIdType>(k), fetched[0]);
  }
  // The input's geometry (origin, whole extent), so that positions are computed as for the input.
  whole = vtkSmartPointer<vtkImageData>::New();
  whole->SetExtent(this->WholeExtent);
  whole->SetOrigin(this->Origin);
  whole->SetSpacing(this->WholeGrid.spacing.data());
  whole->GetPointData()->SetScalars(all);
  return true;
}

//------------------------------------------------------------------------------
bool Pieces::AllOk(bool ok)
{
  Clock clock{ this->Seconds };
  const int mine = ok ? 1 : 0;
  int all = 0;
  this->Controller->AllReduce(&mine, &all, 1, vtkCommunicator::MIN_OP);
  this->Sent += sizeof(int);
  return all == 1;
}

bool Pieces::Agree(vtkAlgorithm* filter, const char* name, bool ok, const char* what)
{
  if (this->AllOk(ok))
  {
    return true;
  }
  if (ok)
  {
    vtkErrorWithObjectMacro(
      filter, << name << " stopped: " << what << " failed on another rank (see its error).");
  }
  return false;
}

void Pieces::MaxInPlace(std::vector<double>& values)
{
  Clock clock{ this->Seconds };
  std::vector<double> out(values.size());
  this->Controller->AllReduce(values.data(), out.data(),
    static_cast<vtkIdType>(values.size()), vtkCommunicator::MAX_OP);
  this->Sent += values.size() * sizeof(double);
  values.swap(out);
}

vtkIdType Pieces::Sum(vtkIdType value)
{
  Clock clock{ this->Seconds };
  vtkIdType out = 0;
  this->Controller->AllReduce(&value, &out, 1, vtkCommunicator::SUM_OP);
  this->Sent += sizeof(vtkIdType);
  return out;
}

std::vector<std::int32_t> Pieces::Concatenate(const std::vector<std::int32_t>& values)
{
  Clock clock{ this->Seconds };
  const vtkIdType mine = static_cast<vtkIdType>(values.size());
  std::vector<vtkIdType> lengths(this->Ranks);
  this->Controller->AllGather(&mine, lengths.data(), 1);
  std::vector<vtkIdType> offsets(this->Ranks, 0);
  for (int r = 1; r < this->Ranks; ++r)
  {
    offsets[r] = offsets[r - 1] + lengths[r - 1];
  }
  std::vector<int> out(static_cast<std::size_t>(offsets.back() + lengths.back()));
  std::vector<int> send(values.begin(), values.end());
  this->Controller->AllGatherV(send.data(), out.data(), mine, lengths.data(), offsets.data());
  this->Sent += sizeof(vtkIdType) + values.size() * sizeof(int);
  return std::vector<std::int32_t>(out.begin(), out.end());
}

std::vector<double> Pieces::PerRank(double value)
{
  Clock clock{ this->Seconds };
  std::vector<double> out(this->Ranks);
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
  for (vtkDataArray* a : arrays)
  {
    fetched.push_back(SameKind(a, n));
  }
  // Which rank holds each point; what to ask each rank for, and where the answers go.
  bool ok = true;
  std::vector<std::vector<std::uint64_t>> want(this->Ranks);
  std::vector<std::vector<vtkIdType>> slots(this->Ranks);
  try
  {
    const rust::Vec<std::uint32_t> owners =
      bridge::piece_point_owners(this->WholeGrid, this->Extents(), ids);
    for (vtkIdType k = 0; k < n; ++k)
    {
      const std::uint32_t o = owners[k];
      if (static_cast<int>(o) >= this->Ranks || static_cast<int>(o) == this->Me)
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
  if (!ok)
  {
    // Ask for nothing, but take part in the exchange: the other ranks wait for it.
    for (auto& w : want)
    {
      w.clear();
    }
  }

  // Requests: each message carries this rank's number of arrays, then the point indices.
  std::vector<std::vector<std::uint64_t>> asked(this->Ranks);
  std::vector<std::uint64_t> theirArrays(this->Ranks, 0);
  for (int q = 0; q < this->Ranks; ++q)
  {
    if (q == this->Me)
    {
      continue;
    }
    vtkNew<vtkTypeUInt64Array> mine;
    mine->SetNumberOfValues(static_cast<vtkIdType>(want[q].size() + 1));
    mine->SetValue(0, arrays.size());
    std::copy(want[q].begin(), want[q].end(), mine->GetPointer(1));
    vtkNew<vtkTypeUInt64Array> theirs;
    if (this->Me < q)
    {
      this->Controller->Send(mine, q, RequestTag);
      this->Controller->Receive(theirs, q, RequestTag);
    }
    else
    {
      this->Controller->Receive(theirs, q, RequestTag);
      this->Controller->Send(mine, q, RequestTag);
    }
    this->Sent += mine->GetNumberOfValues() * sizeof(std::uint64_t);
    if (theirs->GetNumberOfValues() > 0)
    {
      theirArrays[q] = theirs->GetValue(0);
      asked[q].assign(theirs->GetPointer(1), theirs->GetPointer(0) + theirs->GetNumberOfValues());
    }
  }

  // Responses: one message per array of the responding rank.
  for (int q = 0; q < this->Ranks; ++q)
  {
    if (q == this->Me)
    {
      continue;
    }
    // What q asked for, from this rank's arrays (an answer of no tuples, refused by q, when this
    // rank does not hold every point asked for).
    std::vector<vtkSmartPointer<vtkDataArray>> answers;
    vtkNew<vtkIdList> held;
    if (!asked[q].empty())
    {
      try
      {
        const rust::Vec<std::int64_t> local = bridge::piece_local_ids(
          this->WholeGrid, this->OwnExtent(), { asked[q].data(), asked[q].size() });
        if (std::find(local.begin(), local.end(), -1) == local.end())
        {
          held->SetNumberOfIds(static_cast<vtkIdType>(local.size()));
          std::copy(local.begin(), local.end(), held->GetPointer(0));
        }
      }
      catch (const rust::Error& e)
      {
        error = e.what();
        ok = false;
      }
    }
    for (vtkDataArray* a : arrays)
    {
      auto answer = SameKind(a, held->GetNumberOfIds());
      if (held->GetNumberOfIds() > 0)
      {
        a->GetTuples(held, answer);
      }
      answers.push_back(answer);
    }
    // Arrays go only where points were asked for, as many as both ranks hold (non-empty pieces
    // of one image hold the same point arrays; a difference is an error below).
    const std::size_t common = std::min(arrays.size(), static_cast<std::size_t>(theirArrays[q]));
    const std::size_t toSend = asked[q].empty() ? 0 : common;
    const std::size_t toReceive = want[q].empty() ? 0 : common;
    if (!want[q].empty() && theirArrays[q] != arrays.size())
    {
      error = "rank " + std::to_string(q) + " holds other point arrays than this rank";
      ok = false;
    }
    for (std::size_t m = 0; m < std::max(toSend, toReceive); ++m)
    {
      const bool send = m < toSend;
      const bool receive = m < toReceive;
      vtkSmartPointer<vtkDataArray> incoming = receive ? SameKind(arrays[m], 0) : nullptr;
      if (this->Me < q)
      {
        if (send)
        {
          this->Controller->Send(answers[m], q, ResponseTag);
        }
        if (receive)
        {
          this->Controller->Receive(incoming, q, ResponseTag);
        }
      }
      else
      {
        if (receive)
        {
          this->Controller->Receive(incoming, q, ResponseTag);
        }
        if (send)
        {
          this->Controller->Send(answers[m], q, ResponseTag);
        }
      }
      if (send)
      {
        this->Sent += answers[m]->GetNumberOfValues() * answers[m]->GetDataTypeSize();
      }
      if (!receive)
      {
        continue;
      }
      if (incoming->GetNumberOfTuples() != static_cast<vtkIdType>(slots[q].size()) ||
        incoming->GetNumberOfComponents() != fetched[m]->GetNumberOfComponents())
      {
        error = "rank " + std::to_string(q) + " answered with other arrays or points than asked";
        ok = false;
        continue;
      }
      fetched[m]->InsertTuples(IdList(slots[q]), IdList(0, incoming->GetNumberOfTuples()), incoming);
    }
  }
  return ok;
}

} // namespace vtkDiamonds
