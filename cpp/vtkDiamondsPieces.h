// Internal to the Diamonds VTK module (not installed, not wrapped): the ranks of a distributed
// pipeline (ParaView's MPI engine, pvbatch or pvserver) and what the filters move between them.
//
// The core decides what is needed (diamonds::hierarchy::piece, diamonds::progressive's seams); these
// classes only move it, over the global vtkMultiProcessController. Ranks: agreement on success,
// element-wise maxima and concatenations, lists exchanged between the ranks that have something
// for each other. Pieces (an image's): the extents of all pieces, point tuples fetched from the
// ranks that hold them (asked for by point ids or by boxes). Point-to-point
// messages go pair by pair in one global order (every rank handles its pairs (a, b), a < b, sorted),
// so that blocking sends never deadlock.
#ifndef vtkDiamondsPieces_h
#define vtkDiamondsPieces_h

#include "vtkDiamondsBridge.h"
#include "vtkDiamondsHierarchyCache.h"

#include "vtkSmartPointer.h"
#include "vtkType.h"

#include <chrono>
#include <cstdint>
#include <functional>
#include <string>
#include <utility>
#include <vector>

class vtkAlgorithm;
class vtkDataArray;
class vtkDataSet;
class vtkFieldData;
class vtkIdList;
class vtkImageData;
class vtkInformation;
class vtkMultiProcessController;
class vtkPointData;

namespace vtkDiamonds
{
// The ids of a vtkIdList: `ids`, or `count` consecutive ids from `first`.
vtkSmartPointer<vtkIdList> IdList(const std::vector<vtkIdType>& ids);
vtkSmartPointer<vtkIdList> IdList(vtkIdType first, vtkIdType count);

// The ranks of a distributed execution and what passes between them, whatever the data: agreement
// on failures, reductions, and lists exchanged between the ranks that have something for each
// other. Every step is collective (all ranks call it, in the same order) and counts the bytes this
// rank sent and the seconds it spent.
class Ranks
{
public:
  // The controller of a run on more than one rank, else nullptr (a serial run).
  static vtkMultiProcessController* DistributedController();

  explicit Ranks(vtkMultiProcessController* controller);

  int Rank() const { return this->Me; }
  int Size() const { return this->Count; }

  // Collective: true on every rank when `ok` is true on every rank.
  bool AllOk(bool ok);
  // Collective: true on every rank when `ok` is true on every rank and no rank's execution of
  // `filter` was aborted (CheckAbort: its AbortExecute or an abort upstream). Where `ok` held but
  // another rank failed, an error on `filter` saying that `name` stopped because `what` failed on
  // another rank (which reported its own error). When a rank was aborted, every rank ends the
  // execution aborted, without an error: AbortOutput set (the executive empties the outputs and
  // marks them ABORTED alike on every rank), and Failed() is 1.
  //
  // A rank that reaches Agree while other ranks share a step (Share) takes part in their
  // exchanges, contributing nothing, until they reach it too: a rank with an empty piece, or one
  // whose part of the step failed, never leaves them waiting.
  bool Agree(vtkAlgorithm* filter, const char* name, bool ok, const char* what);
  // What RequestData returns after an Agree that failed: 1 after an abort (not an error, as a
  // serial filter's abort), else 0.
  int Failed() const { return this->Aborted ? 1 : 0; }
  // Collective among the ranks doing a shared step (the others are in Agree): every rank's
  // `bytes`, concatenated in rank order into `all`, with their `lengths`. False on every rank
  // when a rank failed or was aborted (agreed on as Agree does, with its error or abort; the
  // next Agree then returns false at once) or could not allocate what it receives.
  bool Share(vtkAlgorithm* filter, const char* name, const unsigned char* bytes, std::size_t size,
    std::vector<unsigned char>& all, std::vector<vtkIdType>& lengths);
  // Whether a Share stopped this step: the failure is agreed on, and the next Agree returns false
  // without a collective.
  bool Stopped() const { return this->StoppedInStep; }
  // This rank's part of a step between two collective ones: runs `work` (a callable returning false
  // when it failed and reported why) and returns its outcome. Whatever `work` throws is caught and
  // reported on `filter` here: a std::bad_alloc as the serial filters report running out of memory,
  // a core error (rust::Error, e.g. the core's out of memory) as "`name` `failure`: error". So the
  // rank always reaches the next collective step (an Agree), where the other ranks wait for it, and
  // all ranks leave together. Every distributed filter runs each step between collectives in Run.
  template <class Work>
  static bool Run(vtkAlgorithm* filter, const char* name, const char* failure, Work&& work)
  {
    try
    {
      return work();
    }
    catch (...)
    {
      ReportCaught(filter, name, failure);
      return false;
    }
  }

  // Collective: element-wise maximum over the ranks, in place. The result buffer is allocated
  // and agreed on before the all-reduce (Allocated): false on every rank, `values` unchanged and
  // `error` set, when a rank could not allocate it.
  bool MaxInPlace(std::vector<double>& values, std::string& error);
  // Collective: sum over the ranks.
  vtkIdType Sum(vtkIdType value);
  // Collective: every rank's `values`, concatenated in rank order into `all`; allocated and agreed
  // on as MaxInPlace.
  bool Concatenate(
    const std::vector<std::int32_t>& values, std::vector<std::int32_t>& all, std::string& error);
  // Collective: sends each rank q its list of `counts[q]` values of `values` (the lists in rank
  // order, this rank's own skipped) and receives into `received` what every other rank sent this
  // one, in rank order. First every rank learns who sends to whom (an all-gather of one bit per
  // rank pair, P²/8 bytes in all); then only the pairs with a list in either direction exchange,
  // pairwise in one global pair order (as Fetch), so a rank receives only what is addressed to
  // it and talks only to the ranks that have something for it or it for them (before, every pair
  // of ranks exchanged three messages per round, empty or not). `moved` tells every rank alike
  // whether any rank sent anything. False with `error` set when `counts` is not one per rank (this
  // rank then sends nothing but takes part) or a rank could not allocate what it receives (every
  // pair still completes its exchange; only the two ranks of the pair know).
  template <class T>
  bool Exchange(rust::Slice<const std::size_t> counts, const T* values, std::vector<T>& received,
    bool& moved, std::string& error)
  {
    received.clear();
    return this->ExchangeBytes(
      counts, sizeof(T), values,
      [&](vtkIdType bytes) -> void* {
        const std::size_t old = received.size();
        received.resize(old + static_cast<std::size_t>(bytes) / sizeof(T));
        return received.data() + old;
      },
      moved, error);
  }
  // Collective: one value per rank.
  std::vector<double> PerRank(double value);

  // Collective: the per-rank figures of a distributed execution, added to `fieldData`:
  // `cellsName` (this rank's `cells`, e.g. TetrahedraPerRank), SecondsPerRank (since `started`),
  // BytesSentPerRank, ExchangeSecondsPerRank and PeakMemoryPerRank (bytes, the process's peak
  // resident set), one value per rank.
  void AddFigures(vtkFieldData* fieldData, const char* cellsName, vtkIdType cells,
    std::chrono::steady_clock::time_point started);

  // Bytes this rank sent so far (point-to-point and collective contributions), and seconds spent
  // in the steps above (exchanging and waiting for the other ranks).
  double BytesSent() const { return this->Sent; }
  double ExchangeSeconds() const { return this->Seconds; }

protected:
  friend class SharedStep;

  // Reports the exception being handled (see Run).
  static void ReportCaught(vtkAlgorithm* filter, const char* name, const char* failure);

  // Concatenate of `count` values at `values`, with every rank's length in `lengths`.
  template <class T>
  bool ConcatenateValues(const T* values, vtkIdType count, std::vector<T>& all,
    std::vector<vtkIdType>& lengths, std::string& error);

  // Collective: runs `allocate` (which may throw std::bad_alloc) and agrees that every rank
  // could, before a collective that uses its buffers: a rank out of memory fails here with the
  // others, never inside the exchange. Otherwise false on every rank, with `error` saying that
  // this rank, or another one, ran out of memory for `what`.
  bool Allocated(const std::function<void()>& allocate, const std::string& what, std::string& error);

  // Point-to-point with rank `q` in the global pair order (the lower rank sends first): sends
  // `bytes` bytes at `out` and receives what `q` sends into the buffer `receive(size)` gives (of
  // `size` bytes; it may throw std::bad_alloc). The sizes go first, then whether each rank has its
  // buffer, and the payloads only when both have: a rank out of memory never leaves the other
  // blocked in a send or a receive. Returns false, with `error` set, when either could not allocate.
  bool Swap(int q, const void* out, vtkIdType bytes, const std::function<void*(vtkIdType)>& receive,
    std::string& error);

  // Exchange of `counts[q]` elements of `size` bytes at `values`, received where `receive(bytes)`
  // says (appended).
  bool ExchangeBytes(rust::Slice<const std::size_t> counts, std::size_t size, const void* values,
    const std::function<void*(vtkIdType)>& receive, bool& moved, std::string& error);

  vtkMultiProcessController* Controller;
  int Me = 0;
  int Count = 1;
  double Sent = 0.0;
  double Seconds = 0.0;
  bool Aborted = false;        // an Agree found a rank aborted
  bool StoppedInStep = false; // a Share agreed on a failure or an abort
};

// The bridge's exchange (diamonds::bridge::PieceExchange) through Ranks::Share, for a step that
// the ranks share inside the core (Adaptive Isosurface's two-sided bound check).
class SharedStep final : public diamonds::bridge::PieceExchange
{
public:
  SharedStep(Ranks& ranks, vtkAlgorithm* filter, const char* name)
    : RanksOfStep(ranks)
    , Filter(filter)
    , Name(name)
  {
  }

  bool all_gather(rust::Slice<const std::uint8_t> bytes, rust::Vec<std::uint8_t>& all,
    rust::Vec<std::uint64_t>& lengths) noexcept override;

private:
  Ranks& RanksOfStep;
  vtkAlgorithm* Filter;
  const char* Name;
};

// The pieces of a distributed image (or rectilinear grid): every rank's extent in the whole one,
// and the exchanges of point data between them.
class Pieces : public Ranks
{
public:
  // Collective: gathers every rank's extent. `wholeExtent`, `origin` and `spacing` describe the
  // whole image (the same on every rank); `extent` is this rank's piece (empty: any max < min).
  Pieces(vtkMultiProcessController* controller, const int wholeExtent[6], const int extent[6],
    const double origin[3], const double spacing[3]);
  // Collective: the same for a filter's input `input` (its piece, a vtkImageData or a
  // vtkRectilinearGrid; empty when it has no points) and its pipeline information `inInfo` (whole
  // extent, and an image's origin and spacing when given). A rectilinear grid's geometry is its
  // coordinates (GatherWhole gathers them): Whole() then has origin 0 and spacing 1.
  Pieces(vtkMultiProcessController* controller, vtkInformation* inInfo, vtkDataSet* input);

  // The whole grid (origin at its first point).
  const bridge::GridSpec& Whole() const { return this->WholeGrid; }
  // Length of the whole grid's diagonal: what relative tolerances are relative to.
  double WholeDiagonal() const;
  // Where the whole grid's points are, by vtkImageData's formula (the origin, the whole extent's
  // minima and the spacing), as the serial filters place them.
  bridge::PointFrame Frame() const;
  // Every rank's extent, six values each (VTK order), relative to the whole extent's first point.
  rust::Slice<const std::int64_t> Extents() const { return { this->All.data(), this->All.size() }; }
  rust::Slice<const std::int64_t> OwnExtent() const { return { this->All.data() + 6 * this->Me, 6 }; }

  // Collective: the tuples of `arrays` (point arrays over this rank's extent) at the
  // whole-grid point indices `ids` (none of them in this rank's extent), fetched from the first
  // rank holding each. `fetched` receives one array per input array (same type, components and
  // name) with a tuple per id. Returns false with `error` set when a point is held by no rank.
  bool Fetch(rust::Slice<const std::uint64_t> ids, const std::vector<vtkDataArray*>& arrays,
    std::vector<vtkSmartPointer<vtkDataArray>>& fetched, std::string& error);
  // Collective: the point data a piece's output takes from input points, as a table (`sources`:
  // Surface::piece_sources, IntervalVolume::piece_sources; null on a rank without output, which
  // fetches nothing but takes part): into `table`, every point array of `in` (this rank's piece;
  // null when empty) but `skip` (none when null) and the ghost array, with the same attribute roles,
  // a tuple per row of the table — this rank's points, then those fetched from the ranks holding
  // them. False when it failed on this rank (a point held by no rank, out of memory), reported on
  // `filter`, named `name`, as Run reports; the caller agrees on it.
  bool SourceTable(vtkAlgorithm* filter, const char* name, const bridge::PointSources* sources,
    vtkPointData* in, vtkDataArray* skip, vtkPointData* table);
  // Collective: the same for the boxes of points of `requests` (bridge::piece_requests: a few
  // boxes asked of each rank holding points this one needs, none of this rank), a few integers
  // per box crossing instead of a point index per tuple. `fetched` receives the tuples of the boxes,
  // rank after rank, each box's points x fastest, the order the core takes them in.
  bool FetchBoxes(const bridge::SampleRequests& requests, const std::vector<vtkDataArray*>& arrays,
    std::vector<vtkSmartPointer<vtkDataArray>>& fetched, std::string& error);

  // Collective: the whole dataset on this rank, for filters that need all of it (Adaptive
  // Isosurface, Material Interface Approximation). Every rank's piece of the point arrays
  // `pointArrays` and cell arrays `cellArrays` of `input` (this rank's piece; none for an empty
  // piece) goes to every rank, one all-gather per array (each rank sends its piece once, whatever
  // the number of ranks), and is put together by the pieces' extents on a dataset of the whole
  // extent and of `input`'s type: a vtkImageData with the input's origin and spacing, or a
  // vtkRectilinearGrid whose coordinates are gathered the same way. The first point array is the
  // active scalars. An empty piece gets no dataset. Ranks with a piece must pass arrays of the
  // same types and components in the same order. Returns false with `error` set when the pieces do
  // not cover the whole extent, hold other arrays, or an array exceeds 2 GiB (MPI counts).
  bool GatherWhole(vtkDataSet* input, const std::vector<vtkDataArray*>& pointArrays,
    const std::vector<vtkDataArray*>& cellArrays, vtkSmartPointer<vtkDataSet>& whole,
    std::string& error);

private:
  // Collective, Fetch's and FetchBoxes' exchange: sends each rank q the words `want[q]` (point
  // indices, or boxes), for `tuples[q]` tuples of each of `arrays`, and hands each rank's answer
  // for array m to `place(q, m, answer)`; answers what the others ask with the tuples at the
  // indices `held(words)` gives (among this rank's points; -1 or an error: not held, answered
  // with none, refused by the asking rank). `ok` false (this rank failed before, `error` set):
  // asks for nothing but takes part. False, with `error` set, on the first failure.
  bool Ask(std::vector<std::vector<std::uint64_t>>& want, const std::vector<std::size_t>& tuples,
    const std::function<rust::Vec<std::int64_t>(const std::vector<std::uint64_t>&)>& held,
    const std::function<void(int, std::size_t, vtkDataArray*)>& place,
    const std::vector<vtkDataArray*>& arrays, bool ok, std::string& error);

  struct InputGeometry;
  Pieces(vtkMultiProcessController* controller, const InputGeometry& geometry);

  int WholeLo[3] = { 0, 0, 0 };
  int WholeExtent[6] = { 0, -1, 0, -1, 0, -1 };
  double Origin[3] = { 0.0, 0.0, 0.0 };
  bridge::GridSpec WholeGrid{};
  std::vector<std::int64_t> All;
};

// The whole image a distributed image filter puts together on every rank with a piece (Adaptive
// Isosurface, Adaptive Interval Volume: exact, not scalable), kept between executions while no
// rank's input changed.
class WholeImage
{
public:
  // What it is put together from: the processed array, every rank's extent. (The other point
  // arrays are not gathered: the filters fetch them at their output's points, SourceTable.)
  struct Key
  {
    InputKey Input;
    std::vector<std::int64_t> Extents;
    bool operator==(const Key& o) const { return Input == o.Input && Extents == o.Extents; }
  };
  // This rank's key: the array `processed` of `input` as read (none on an empty piece).
  static Key KeyOf(const Pieces& pieces, vtkImageData* input, vtkDataArray* processed);

  // Collective: whether any rank's key differs from the one of its last gather (then every rank
  // gathers again: release what depends on the image first).
  bool Stale(Pieces& pieces, const Key& key) const;
  // Collective: gathers `samples` (the processed array, or its samples as the core reads them; none
  // on an empty piece) of every rank's piece into the whole image (GatherWhole; its active
  // scalars). False on every rank when it failed anywhere (an error on `filter`, named `name`,
  // where it failed; agreed on as Pieces::Agree): no image is kept.
  bool Gather(vtkAlgorithm* filter, const char* name, Pieces& pieces, vtkImageData* input,
    vtkDataArray* samples, const Key& key);
  // The image (none on an empty piece, or after a failed gather).
  vtkImageData* Get() const;

private:
  vtkSmartPointer<vtkImageData> Image;
  Key Built;
};

} // namespace vtkDiamonds

#endif
