// Internal to the Diamonds VTK module (not installed, not wrapped): the diamond hierarchy
// vtkAdaptiveTetrahedra and vtkAdaptiveIsosurface keep between executions.
//
// vtkDiamonds::HierarchyCache picks the samples of the processed array (in place, or a converted copy
// for 64-bit integers and non-contiguous arrays), builds the diamond hierarchy through the bridge with
// progress and abort, and keeps it until the array, its values (MTime), its name or the image geometry
// change. Optionally keeps the samples alive for queries that read them again (isosurfaces), and the
// isosurface state (the adaptive mesh of the last isosurface query), which is created with each
// hierarchy and dropped with it.
#ifndef vtkDiamondsHierarchyCache_h
#define vtkDiamondsHierarchyCache_h

#include "vtkDiamondsBridge.h"

#include "vtkSmartPointer.h"
#include "vtkType.h"

#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

class vtkAlgorithm;
class vtkDataArray;
class vtkImageData;

namespace vtkDiamonds
{
struct FilterText;

// The samples of `array` as the core reads them, in `samples` with their `type`: the array itself
// when the core reads its type in place, else a converted (64-bit integers, exact below 2^53) or
// contiguous copy. Reports an error on `filter` and returns false for types the core cannot read.
bool CoreSamples(vtkAlgorithm* filter, const FilterText& text, vtkDataArray* array,
  vtkSmartPointer<vtkDataArray>& samples, bridge::ScalarType& type);

// What a hierarchy is built from: an array on an image's geometry. The array pointer is an
// identity only (never dereferenced); together with the array's MTime it detects a new or modified
// array.
struct InputKey
{
  const void* Array = nullptr;
  vtkMTimeType ArrayMTime = 0;
  std::string Name;
  int DataType = 0;
  std::array<int, 6> Extent{};
  std::array<double, 3> Origin{};
  std::array<double, 3> Spacing{};

  InputKey() = default;
  // `array` (null for none) on `input`.
  InputKey(vtkImageData* input, vtkDataArray* array);
  bool operator==(const InputKey& o) const;
};

class HierarchyCache
{
public:
  // What the hierarchy serves. Tetrahedra: the full hierarchy (per-diamond error bounds,
  // 2 bytes per point). Isosurfaces: the isosurface-only hierarchy (no per-diamond records: each
  // query measures its errors at the samples that decide its surface), with a reference to the
  // samples it was built from, which its queries read again (costs nothing when the input keeps its
  // array anyway).
  enum class Use
  {
    Tetrahedra,
    Isosurfaces
  };
  explicit HierarchyCache(Use use);

  // Makes the cached hierarchy that of `array` on `input`'s geometry, building it when needed with
  // progress mapped onto [from, to] and counting the build in `builds`, then checks for an abort. Returns true to go on; false to stop, with `result` set to what
  // RequestData returns (1 after an abort: empty outputs are not an error; 0 after a failure).
  bool Prepare(vtkAlgorithm* filter, const FilterText& text, vtkImageData* input,
    vtkDataArray* array, double from, double to, vtkIdType& builds, int& result);

  bool HasHierarchy() const { return this->Hierarchy.has_value(); }
  const bridge::Hierarchy& GetHierarchy() const { return **this->Hierarchy; }
  // The isosurface state of the cached hierarchy (only with a hierarchy): created empty with each
  // build and released with the hierarchy, so a state never outlives the hierarchy it belongs to.
  bridge::IsoState& GetIsoState() { return **this->IsoState; }
  // Clears the isosurface state (when there is one): the next extraction refines from the root
  // and measures its errors again.
  void ClearIsosurfaceState()
  {
    if (this->IsoState)
    {
      (*this->IsoState)->clear();
    }
  }
  // The samples the hierarchy was built from (only for isosurfaces) and their type.
  rust::Slice<const std::uint8_t> GetSamples() const;
  bridge::ScalarType GetSampleType() const { return this->SampleType; }

  // Bytes of the hierarchy in use. Tetrahedra: the per-diamond records. Isosurfaces: the
  // isodiamond hierarchy's when one is kept (PrepareIsodiamonds); else what the full hierarchy's
  // extraction holds: the samples it reads again and the isosurface state's caches and mesh.
  vtkIdType GetMemorySize() const;
  void Release();

  // Makes the kept isodiamond hierarchy (Weiss & De Floriani §6-§7) that of `levels` (one isovalue,
  // or the two bounds of an interval volume), relevant or `minimal`, building it from the cached
  // hierarchy and samples when they, `levels` or `minimal` changed, counting the build in `builds`;
  // the build reports progress from `from` to `to` on `filter` and stops on AbortExecute. Returns
  // null with `result` 1 when aborted (nothing kept, nothing reported: the output stays empty), or
  // with `result` 0 after reporting an error on `filter`.
  const bridge::Isodiamonds* PrepareIsodiamonds(vtkAlgorithm* filter, const FilterText& text,
    const std::vector<double>& levels, bool minimal, double from, double to, vtkIdType& builds,
    int& result);
  // Drops the isodiamond hierarchy (the full hierarchy is in use again).
  void ReleaseIsodiamonds();

private:
  enum class Status
  {
    Kept,    // the cached hierarchy matches the array and geometry
    Built,   // a new hierarchy was built
    Aborted, // the build was aborted (AbortExecute): no hierarchy
    Failed   // an error was reported on the filter: no hierarchy
  };

  // Prepare's work without the bookkeeping.
  Status Update(vtkAlgorithm* filter, const FilterText& text, vtkImageData* input,
    vtkDataArray* array, double from, double to);

  Use Purpose;
  std::optional<rust::Box<bridge::Hierarchy>> Hierarchy;
  std::optional<rust::Box<bridge::IsoState>> IsoState;
  std::optional<rust::Box<bridge::Isodiamonds>> Isodiamonds;
  std::vector<double> IsodiamondLevels;
  bool IsodiamondMinimal = false;
  InputKey Built;
  vtkSmartPointer<vtkDataArray> Samples;
  bridge::ScalarType SampleType = bridge::ScalarType::F64;
};

} // namespace vtkDiamonds

#endif
