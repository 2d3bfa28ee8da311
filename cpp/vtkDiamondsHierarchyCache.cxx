#include "vtkDiamondsHierarchyCache.h"

#include "vtkDiamondsArraySelection.h" // FilterText
#include "vtkDiamondsImageGeometry.h"
#include "vtkDiamondsProgress.h"

#include "vtkAlgorithm.h"
#include "vtkDataArray.h"
#include "vtkDoubleArray.h"
#include "vtkImageData.h"

#include <algorithm>
#include <cmath>
#include <utility>

namespace vtkDiamonds
{
namespace
{
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

} // namespace

//------------------------------------------------------------------------------
bool CoreSamples(vtkAlgorithm* filter, const FilterText& text, vtkDataArray* array,
  vtkSmartPointer<vtkDataArray>& samples, bridge::ScalarType& type)
{
  samples = array;
  std::optional<bridge::ScalarType> inPlace = InPlaceType(array);
  const std::string name = array->GetName() ? array->GetName() : "";
  if (!inPlace && Is64BitInteger(array))
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
      return false;
    }
    vtkWarningWithObjectMacro(filter,
      << "Array \"" << name << "\" holds 64-bit integers (" << array->GetDataTypeAsString()
      << "); they are converted to double for " << text.Name
      << " (exact, all values are below 2^53). The input array keeps its type.");
    samples = vtkSmartPointer<vtkDoubleArray>::New();
    samples->DeepCopy(array);
    inPlace = bridge::ScalarType::F64;
  }
  if (!inPlace)
  {
    vtkErrorWithObjectMacro(filter,
      << "Array \"" << name << "\" has type " << array->GetDataTypeAsString() << ", which "
      << text.Name
      << " does not read. Supported: 8-, 16-, 32- and 64-bit integers, float, double.");
    return false;
  }
  if (!samples->HasStandardMemoryLayout())
  {
    // e.g. a structure-of-arrays or implicit array: the core reads one contiguous buffer.
    vtkSmartPointer<vtkDataArray> contiguous =
      vtkSmartPointer<vtkDataArray>::Take(vtkDataArray::CreateDataArray(samples->GetDataType()));
    contiguous->DeepCopy(samples);
    samples = contiguous;
  }

  type = *inPlace;
  return true;
}

//------------------------------------------------------------------------------
HierarchyCache::HierarchyCache(Use use)
  : Purpose(use)
{
}

InputKey::InputKey(vtkImageData* input, vtkDataArray* array)
  : Array(array)
  , ArrayMTime(array ? array->GetMTime() : 0)
  , Name(array && array->GetName() ? array->GetName() : "")
  , DataType(array ? array->GetDataType() : 0)
{
  const ImageGeometry image(input);
  std::copy(image.Extent, image.Extent + 6, this->Extent.begin());
  std::copy(image.Origin, image.Origin + 3, this->Origin.begin());
  std::copy(image.Spacing, image.Spacing + 3, this->Spacing.begin());
}

bool InputKey::operator==(const InputKey& o) const
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
  if (this->Isodiamonds)
  {
    return static_cast<vtkIdType>((*this->Isodiamonds)->memory_bytes());
  }
  if (!this->Hierarchy)
  {
    return 0;
  }
  std::size_t bytes = (*this->Hierarchy)->metadata_bytes();
  if (this->Purpose == Use::Isosurfaces)
  {
    bytes += this->GetSamples().size() + (*this->IsoState)->memory_bytes();
  }
  return static_cast<vtkIdType>(bytes);
}

void HierarchyCache::ReleaseIsodiamonds()
{
  this->Isodiamonds.reset();
  this->IsodiamondLevels.clear();
}

const bridge::Isodiamonds* HierarchyCache::PrepareIsodiamonds(vtkAlgorithm* filter,
  const FilterText& text, const std::vector<double>& levels, bool minimal, double from, double to,
  vtkIdType& builds, int& result)
{
  if (this->Isodiamonds && this->IsodiamondLevels == levels && this->IsodiamondMinimal == minimal)
  {
    return &**this->Isodiamonds;
  }
  this->ReleaseIsodiamonds();
  ProgressForwarder progress(filter, from, to);
  filter->UpdateProgress(from);
  try
  {
    this->Isodiamonds.emplace(
      (*this->Hierarchy)
        ->build_isodiamonds(this->SampleType, this->GetSamples(),
          rust::Slice<const double>(levels.data(), levels.size()), minimal, progress));
  }
  catch (const rust::Error& e)
  {
    if (progress.Aborted)
    {
      vtkDebugWithObjectMacro(filter, << "Isodiamond hierarchy build aborted.");
      result = 1;
      return nullptr;
    }
    result = 0;
    vtkErrorWithObjectMacro(filter,
      << text.Name << " cannot build the " << (minimal ? "minimal" : "relevant")
      << " isodiamond hierarchy: " << e.what());
    return nullptr;
  }
  this->IsodiamondLevels = levels;
  this->IsodiamondMinimal = minimal;
  ++builds;
  return &**this->Isodiamonds;
}

void HierarchyCache::Release()
{
  this->ReleaseIsodiamonds();
  this->IsoState.reset();
  this->Hierarchy.reset();
  this->Built = InputKey{};
  this->Samples = nullptr;
}

//------------------------------------------------------------------------------
bool HierarchyCache::Prepare(vtkAlgorithm* filter, const FilterText& text, vtkImageData* input,
  vtkDataArray* array, double from, double to, vtkIdType& builds, int& result)
{
  switch (this->Update(filter, text, input, array, from, to))
  {
    case Status::Built:
      ++builds;
      break;
    case Status::Kept:
      break;
    case Status::Aborted:
      result = 1;
      return false;
    case Status::Failed:
      result = 0;
      return false;
  }
  filter->UpdateProgress(to);
  if (filter->CheckAbort())
  {
    result = 1;
    return false;
  }
  return true;
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

  const InputKey key(input, array);
  if (this->Hierarchy && this->Built == key)
  {
    return Status::Kept;
  }
  this->Release();

  vtkSmartPointer<vtkDataArray> samples;
  bridge::ScalarType type{};
  if (!CoreSamples(filter, text, array, samples, type))
  {
    return Status::Failed;
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
      ? bridge::build_isosurface_hierarchy(grid, type, slice)
      : bridge::build_hierarchy(grid, type, slice, progress);
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
  this->SampleType = type;
  if (this->Purpose == Use::Isosurfaces)
  {
    this->Samples = samples;
  }
  return Status::Built;
}
} // namespace vtkDiamonds
