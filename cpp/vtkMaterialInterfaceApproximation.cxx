#include "vtkMaterialInterfaceApproximation.h"

#include "vtkCellArray.h"
#include "vtkCellData.h"
#include "vtkCellDataToPointData.h"
#include "vtkDataArray.h"
#include "vtkDataSet.h"
#include "vtkDoubleArray.h"
#include "vtkFieldData.h"
#include "vtkFloatArray.h"
#include "vtkIdTypeArray.h"
#include "vtkImageData.h"
#include "vtkInformation.h"
#include "vtkInformationVector.h"
#include "vtkIntArray.h"
#include "vtkMatrix3x3.h"
#include "vtkObjectFactory.h"
#include "vtkPointData.h"
#include "vtkPoints.h"
#include "vtkPolyData.h"
#include "vtkRectilinearGrid.h"
#include "vtkSmartPointer.h"
#include "vtkStreamingDemandDrivenPipeline.h"
#include "vtkStringArray.h"
#include "vtkTypeInt32Array.h"
#include "vtkTypeInt64Array.h"
#include "vtkTypeUInt32Array.h"
#include "vtkUnsignedCharArray.h"
#include "vtkUnstructuredGrid.h"

// The cxx bridge and the shared helpers. Kept out of the public header: the VTK wrappers parse it.
#include "vtkDiamondsHierarchyCache.h"

#include <algorithm>
#include <array>
#include <bitset>
#include <cctype>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

vtkStandardNewMacro(vtkMaterialInterfaceApproximation);

namespace
{
namespace bridge = diamonds::bridge;
using vtkDiamonds::FixedSizeCells;
using vtkDiamonds::NamedArray;
using vtkDiamonds::OneValue;

const char* const FilterName = "Material Interface Approximation";

// Case-insensitive comparisons for array-name conventions.
std::string Lower(const std::string& s)
{
  std::string out = s;
  std::transform(out.begin(), out.end(), out.begin(),
    [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return out;
}

// Where an array was found.
struct FoundArray
{
  vtkDataArray* Array = nullptr; // the input's array (identity for the model key)
  bool CellData = false;
};

// The single-component array `name` of `input` (point data first, then cell data); reports an error
// listing the arrays otherwise.
std::optional<FoundArray> FindArray(vtkAlgorithm* filter, vtkDataSet* input,
  const std::string& name, const char* property)
{
  FoundArray found;
  if (vtkDataArray* a = input->GetPointData()->GetArray(name.c_str()))
  {
    found.Array = a;
  }
  else if (vtkDataArray* c = input->GetCellData()->GetArray(name.c_str()))
  {
    found.Array = c;
    found.CellData = true;
  }
  if (!found.Array)
  {
    vtkErrorWithObjectMacro(filter,
      << FilterName << ": the input has no numeric point or cell array named \"" << name
      << "\" (" << property << "). Point arrays: "
      << vtkDiamonds::ArrayNames(input->GetPointData())
      << "; cell arrays: " << vtkDiamonds::ArrayNames(input->GetCellData()) << ".");
    return std::nullopt;
  }
  if (found.Array->GetNumberOfComponents() != 1)
  {
    vtkErrorWithObjectMacro(filter,
      << FilterName << ": array \"" << name << "\" (" << property << ") has "
      << found.Array->GetNumberOfComponents()
      << " components; one value per point or cell is needed. Use Calculator to extract a "
         "component.");
    return std::nullopt;
  }
  return found;
}

// The values of a single-component array as a contiguous float array (the array itself when it
// already is one).
vtkSmartPointer<vtkFloatArray> AsFloat(vtkDataArray* array)
{
  vtkFloatArray* f = vtkFloatArray::SafeDownCast(array);
  if (f && f->HasStandardMemoryLayout())
  {
    return f;
  }
  auto copy = vtkSmartPointer<vtkFloatArray>::New();
  copy->DeepCopy(array);
  copy->SetName(array->GetName());
  return copy;
}

rust::Slice<const float> SliceOf(vtkFloatArray* a)
{
  return rust::Slice<const float>(a->GetPointer(0), static_cast<std::size_t>(a->GetNumberOfValues()));
}

// A vtkCellArray of `count` cells from core offsets (count + 1, or empty for none) and connectivity.
vtkSmartPointer<vtkCellArray> CellsFrom(
  rust::Slice<const std::uint32_t> offsets, rust::Slice<const std::uint32_t> connectivity)
{
  auto cells = vtkSmartPointer<vtkCellArray>::New();
  if (offsets.size() < 2)
  {
    return cells;
  }
  vtkNew<vtkTypeInt64Array> off;
  off->SetNumberOfValues(static_cast<vtkIdType>(offsets.size()));
  std::copy(offsets.begin(), offsets.end(), off->GetPointer(0));
  vtkNew<vtkTypeInt64Array> conn;
  conn->SetNumberOfValues(static_cast<vtkIdType>(connectivity.size()));
  std::copy(connectivity.begin(), connectivity.end(), conn->GetPointer(0));
  cells->SetData(off, conn);
  return cells;
}

vtkSmartPointer<vtkPoints> PointsFrom(rust::Slice<const double> xyz)
{
  vtkNew<vtkDoubleArray> data;
  data->SetNumberOfComponents(3);
  data->SetNumberOfTuples(static_cast<vtkIdType>(xyz.size() / 3));
  std::copy(xyz.begin(), xyz.end(), data->GetPointer(0));
  auto points = vtkSmartPointer<vtkPoints>::New();
  points->SetData(data);
  return points;
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
} // namespace

class vtkMaterialInterfaceApproximation::vtkInternals
{
public:
  std::vector<std::string> FractionArrays;
  std::vector<std::string> FieldArrays;
  std::vector<std::string> MaterialFieldArrays;

  // What the kept model was built from. Array pointers are identities only (never dereferenced).
  struct ModelKey
  {
    std::vector<const void*> Arrays;
    std::vector<vtkMTimeType> ArrayMTimes;
    std::vector<std::string> Names;
    std::array<std::size_t, 3> Dims{};
    std::array<double, 3> Origin{};
    std::array<double, 3> Spacing{};
    const void* Interfaces = nullptr;
    vtkMTimeType InterfacesMTime = 0;
    std::string InterfaceMaterialsArray;

    bool operator==(const ModelKey& o) const
    {
      return this->Arrays == o.Arrays && this->ArrayMTimes == o.ArrayMTimes &&
        this->Names == o.Names && this->Dims == o.Dims && this->Origin == o.Origin &&
        this->Spacing == o.Spacing && this->Interfaces == o.Interfaces &&
        this->InterfacesMTime == o.InterfacesMTime &&
        this->InterfaceMaterialsArray == o.InterfaceMaterialsArray;
    }
  };

  struct MeshKey
  {
    double InterfaceTolerance = 0.0;
    double FieldTolerance = 0.0;
    bool GhostValues = true;
    bool operator==(const MeshKey& o) const
    {
      return this->InterfaceTolerance == o.InterfaceTolerance &&
        this->FieldTolerance == o.FieldTolerance && this->GhostValues == o.GhostValues;
    }
  };

  std::optional<rust::Box<bridge::MaterialModel>> Model;
  ModelKey BuiltModel;
  std::optional<rust::Box<bridge::MaterialMesh>> Mesh;
  MeshKey BuiltMesh;

  void Release()
  {
    this->Mesh.reset();
    this->Model.reset();
    this->BuiltModel = ModelKey{};
  }
};

//------------------------------------------------------------------------------
vtkMaterialInterfaceApproximation::vtkMaterialInterfaceApproximation()
  : InterfaceTolerance(0.15)
  , FieldTolerance(3.0)
  , UseGhostValues(1)
  , SliceOrigin{ 0.0, 0.0, 0.0 }
  , SliceNormal{ 1.0, 0.0, 0.0 }
  , InterfaceMaterialsArray(nullptr)
  , NumberOfModelBuilds(0)
  , NumberOfRefinements(0)
  , Internals(new vtkInternals)
{
  this->SetNumberOfInputPorts(2);
  this->SetNumberOfOutputPorts(3);
  this->SetInterfaceMaterialsArray("InterfaceMaterials");
}

//------------------------------------------------------------------------------
vtkMaterialInterfaceApproximation::~vtkMaterialInterfaceApproximation()
{
  this->SetInterfaceMaterialsArray(nullptr);
  delete this->Internals;
}

//------------------------------------------------------------------------------
// Array lists.
namespace
{
void Resize(vtkObject* self, std::vector<std::string>& list, int n)
{
  const std::size_t size = static_cast<std::size_t>(std::max(n, 0));
  if (list.size() != size)
  {
    list.resize(size);
    self->Modified();
  }
}

void SetAt(vtkObject* self, std::vector<std::string>& list, int i, const char* name)
{
  if (i < 0)
  {
    return;
  }
  const std::string value = name ? name : "";
  if (static_cast<std::size_t>(i) >= list.size())
  {
    list.resize(static_cast<std::size_t>(i) + 1);
  }
  if (list[static_cast<std::size_t>(i)] != value)
  {
    list[static_cast<std::size_t>(i)] = value;
    self->Modified();
  }
}

const char* GetAt(const std::vector<std::string>& list, int i)
{
  return (i >= 0 && static_cast<std::size_t>(i) < list.size())
    ? list[static_cast<std::size_t>(i)].c_str()
    : nullptr;
}
} // namespace

void vtkMaterialInterfaceApproximation::SetNumberOfVolumeFractionArrays(int n)
{
  Resize(this, this->Internals->FractionArrays, n);
}
int vtkMaterialInterfaceApproximation::GetNumberOfVolumeFractionArrays()
{
  return static_cast<int>(this->Internals->FractionArrays.size());
}
void vtkMaterialInterfaceApproximation::SetVolumeFractionArray(int i, const char* name)
{
  SetAt(this, this->Internals->FractionArrays, i, name);
}
const char* vtkMaterialInterfaceApproximation::GetVolumeFractionArray(int i)
{
  return GetAt(this->Internals->FractionArrays, i);
}
void vtkMaterialInterfaceApproximation::AddVolumeFractionArray(const char* name)
{
  SetAt(this, this->Internals->FractionArrays, this->GetNumberOfVolumeFractionArrays(), name);
}
void vtkMaterialInterfaceApproximation::ClearVolumeFractionArrays()
{
  Resize(this, this->Internals->FractionArrays, 0);
}

void vtkMaterialInterfaceApproximation::SetNumberOfFieldArrays(int n)
{
  Resize(this, this->Internals->FieldArrays, n);
}
int vtkMaterialInterfaceApproximation::GetNumberOfFieldArrays()
{
  return static_cast<int>(this->Internals->FieldArrays.size());
}
void vtkMaterialInterfaceApproximation::SetFieldArray(int i, const char* name)
{
  SetAt(this, this->Internals->FieldArrays, i, name);
}
const char* vtkMaterialInterfaceApproximation::GetFieldArray(int i)
{
  return GetAt(this->Internals->FieldArrays, i);
}
void vtkMaterialInterfaceApproximation::AddFieldArray(const char* name)
{
  SetAt(this, this->Internals->FieldArrays, this->GetNumberOfFieldArrays(), name);
}
void vtkMaterialInterfaceApproximation::ClearFieldArrays()
{
  Resize(this, this->Internals->FieldArrays, 0);
}

void vtkMaterialInterfaceApproximation::SetNumberOfMaterialFieldArrays(int n)
{
  Resize(this, this->Internals->MaterialFieldArrays, n);
}
int vtkMaterialInterfaceApproximation::GetNumberOfMaterialFieldArrays()
{
  return static_cast<int>(this->Internals->MaterialFieldArrays.size());
}
void vtkMaterialInterfaceApproximation::SetMaterialFieldArray(int i, const char* name)
{
  SetAt(this, this->Internals->MaterialFieldArrays, i, name);
}
const char* vtkMaterialInterfaceApproximation::GetMaterialFieldArray(int i)
{
  return GetAt(this->Internals->MaterialFieldArrays, i);
}
void vtkMaterialInterfaceApproximation::AddMaterialFieldArray(const char* name)
{
  SetAt(this, this->Internals->MaterialFieldArrays, this->GetNumberOfMaterialFieldArrays(), name);
}
void vtkMaterialInterfaceApproximation::ClearMaterialFieldArrays()
{
  Resize(this, this->Internals->MaterialFieldArrays, 0);
}

//------------------------------------------------------------------------------
void vtkMaterialInterfaceApproximation::SetInterfaceMeshesData(vtkPolyData* meshes)
{
  this->SetInputData(1, meshes);
}

void vtkMaterialInterfaceApproximation::SetInterfaceMeshesConnection(vtkAlgorithmOutput* output)
{
  this->SetInputConnection(1, output);
}

void vtkMaterialInterfaceApproximation::ReleaseModel()
{
  this->Internals->Release();
}

//------------------------------------------------------------------------------
int vtkMaterialInterfaceApproximation::FillInputPortInformation(int port, vtkInformation* info)
{
  if (port == 0)
  {
    info->Set(vtkAlgorithm::INPUT_REQUIRED_DATA_TYPE(), "vtkImageData");
    info->Append(vtkAlgorithm::INPUT_REQUIRED_DATA_TYPE(), "vtkRectilinearGrid");
  }
  else
  {
    info->Set(vtkAlgorithm::INPUT_REQUIRED_DATA_TYPE(), "vtkPolyData");
    info->Set(vtkAlgorithm::INPUT_IS_OPTIONAL(), 1);
  }
  return 1;
}

//------------------------------------------------------------------------------
int vtkMaterialInterfaceApproximation::FillOutputPortInformation(int port, vtkInformation* info)
{
  info->Set(vtkDataObject::DATA_TYPE_NAME(), port == 0 ? "vtkUnstructuredGrid" : "vtkPolyData");
  return 1;
}

//------------------------------------------------------------------------------
int vtkMaterialInterfaceApproximation::RequestUpdateExtent(
  vtkInformation*, vtkInformationVector** inputVector, vtkInformationVector* outputVector)
{
  // Input 0: this process's piece, without ghost levels (as the other Diamonds filters). Input 1:
  // the whole interface meshes on every process.
  vtkInformation* outInfo = outputVector->GetInformationObject(0);
  const int piece = outInfo->Get(vtkStreamingDemandDrivenPipeline::UPDATE_PIECE_NUMBER());
  const int pieces = outInfo->Get(vtkStreamingDemandDrivenPipeline::UPDATE_NUMBER_OF_PIECES());
  vtkInformation* inInfo = inputVector[0]->GetInformationObject(0);
  inInfo->Set(vtkStreamingDemandDrivenPipeline::UPDATE_PIECE_NUMBER(), piece);
  inInfo->Set(vtkStreamingDemandDrivenPipeline::UPDATE_NUMBER_OF_PIECES(), pieces);
  inInfo->Set(vtkStreamingDemandDrivenPipeline::UPDATE_NUMBER_OF_GHOST_LEVELS(), 0);
  if (vtkInformation* meshInfo = inputVector[1]->GetInformationObject(0))
  {
    meshInfo->Set(vtkStreamingDemandDrivenPipeline::UPDATE_PIECE_NUMBER(), 0);
    meshInfo->Set(vtkStreamingDemandDrivenPipeline::UPDATE_NUMBER_OF_PIECES(), 1);
    meshInfo->Set(vtkStreamingDemandDrivenPipeline::UPDATE_NUMBER_OF_GHOST_LEVELS(), 0);
  }
  return 1;
}

//------------------------------------------------------------------------------
int vtkMaterialInterfaceApproximation::RequestData(
  vtkInformation*, vtkInformationVector** inputVector, vtkInformationVector* outputVector)
{
  vtkDataSet* input = vtkDataSet::GetData(inputVector[0]);
  vtkPolyData* interfaceInput = vtkPolyData::GetData(inputVector[1]);
  vtkUnstructuredGrid* tetOutput = vtkUnstructuredGrid::GetData(outputVector, 0);
  vtkPolyData* interfaceOutput = vtkPolyData::GetData(outputVector, 1);
  vtkPolyData* sliceOutput = vtkPolyData::GetData(outputVector, 2);
  if (!input || !tetOutput || !interfaceOutput || !sliceOutput)
  {
    vtkErrorMacro(<< FilterName << " needs a vtkImageData or vtkRectilinearGrid input.");
    return 0;
  }
  // Every error below leaves empty outputs.
  tetOutput->Initialize();
  interfaceOutput->Initialize();
  sliceOutput->Initialize();
  vtkInternals& internals = *this->Internals;

  // ---- Parameters.
  for (const auto& t : { std::make_pair("InterfaceTolerance", this->InterfaceTolerance),
         std::make_pair("FieldTolerance", this->FieldTolerance) })
  {
    if (!std::isfinite(t.second) || t.second < 0.0)
    {
      vtkErrorMacro(<< FilterName << ": " << t.first << " must be a finite number >= 0 (got "
                    << t.second << ").");
      return 0;
    }
  }
  for (int axis = 0; axis < 3; ++axis)
  {
    if (!std::isfinite(this->SliceOrigin[axis]) || !std::isfinite(this->SliceNormal[axis]))
    {
      vtkErrorMacro(<< FilterName << ": SliceOrigin and SliceNormal must be finite.");
      return 0;
    }
  }

  if (input->GetNumberOfPoints() == 0)
  {
    // Not an error: e.g. an empty piece of a parallel run.
    vtkDebugMacro(<< "The input is empty; the outputs are empty.");
    return 1;
  }

  // ---- The grid.
  bridge::GridSpec grid;
  if (auto* image = vtkImageData::SafeDownCast(input))
  {
    if (!image->GetDirectionMatrix()->IsIdentity())
    {
      vtkErrorMacro(<< FilterName
                    << ": the input image is oriented (its direction matrix is not the identity); "
                       "only axis-aligned images are supported. Apply Resample To Image first.");
      return 0;
    }
    int dims[3];
    int extent[6];
    double origin[3];
    double spacing[3];
    image->GetDimensions(dims);
    image->GetExtent(extent);
    image->GetOrigin(origin);
    image->GetSpacing(spacing);
    for (int axis = 0; axis < 3; ++axis)
    {
      grid.dims[axis] = static_cast<std::size_t>(std::max(dims[axis], 0));
      grid.origin[axis] = origin[axis] + extent[2 * axis] * spacing[axis];
      grid.spacing[axis] = spacing[axis];
    }
  }
  else if (auto* rectilinear = vtkRectilinearGrid::SafeDownCast(input))
  {
    std::vector<double> coords[3];
    vtkDataArray* arrays[3] = { rectilinear->GetXCoordinates(), rectilinear->GetYCoordinates(),
      rectilinear->GetZCoordinates() };
    for (int axis = 0; axis < 3; ++axis)
    {
      vtkDataArray* a = arrays[axis];
      const vtkIdType n = a ? a->GetNumberOfTuples() : 0;
      coords[axis].resize(static_cast<std::size_t>(n));
      for (vtkIdType i = 0; i < n; ++i)
      {
        coords[axis][static_cast<std::size_t>(i)] = a->GetComponent(i, 0);
      }
    }
    try
    {
      grid = bridge::grid_from_coordinates(
        rust::Slice<const double>(coords[0].data(), coords[0].size()),
        rust::Slice<const double>(coords[1].data(), coords[1].size()),
        rust::Slice<const double>(coords[2].data(), coords[2].size()));
    }
    catch (const rust::Error& e)
    {
      vtkErrorMacro(<< FilterName << " cannot use this rectilinear grid: " << e.what());
      return 0;
    }
  }
  else
  {
    vtkErrorMacro(<< FilterName << " needs a vtkImageData or vtkRectilinearGrid input, not a "
                  << input->GetClassName() << ".");
    return 0;
  }

  // ---- The arrays: the selected fraction arrays, else every array named like a fraction.
  std::vector<std::string> fractionNames = internals.FractionArrays;
  fractionNames.erase(std::remove(fractionNames.begin(), fractionNames.end(), std::string()),
    fractionNames.end());
  if (fractionNames.empty())
  {
    for (vtkFieldData* data : { static_cast<vtkFieldData*>(input->GetPointData()),
           static_cast<vtkFieldData*>(input->GetCellData()) })
    {
      for (int i = 0; i < data->GetNumberOfArrays(); ++i)
      {
        vtkDataArray* a = data->GetArray(i);
        const char* n = data->GetArrayName(i);
        if (a && n && a->GetNumberOfComponents() == 1 &&
          Lower(n).find("fraction") != std::string::npos &&
          std::find(fractionNames.begin(), fractionNames.end(), n) == fractionNames.end())
        {
          fractionNames.emplace_back(n);
        }
      }
    }
    if (fractionNames.size() < 2)
    {
      vtkErrorMacro(<< FilterName
                    << ": select the volume-fraction arrays, one per material, at least 2 "
                       "(VolumeFractionArrays); none was selected and the input has "
                    << fractionNames.size()
                    << " array(s) named like a fraction. Point arrays: "
                    << vtkDiamonds::ArrayNames(input->GetPointData())
                    << "; cell arrays: " << vtkDiamonds::ArrayNames(input->GetCellData()) << ".");
      return 0;
    }
  }
  if (fractionNames.size() < 2)
  {
    vtkErrorMacro(<< FilterName << ": " << fractionNames.size()
                  << " volume-fraction array selected (\"" << fractionNames[0]
                  << "\"); at least 2 materials are needed, one fraction array each "
                     "(VolumeFractionArrays).");
    return 0;
  }
  std::vector<std::string> fieldNames = internals.FieldArrays;
  fieldNames.erase(
    std::remove(fieldNames.begin(), fieldNames.end(), std::string()), fieldNames.end());
  std::vector<std::string> materialFieldNames = internals.MaterialFieldArrays;
  materialFieldNames.erase(
    std::remove(materialFieldNames.begin(), materialFieldNames.end(), std::string()),
    materialFieldNames.end());
  {
    std::vector<std::string> all = fractionNames;
    all.insert(all.end(), fieldNames.begin(), fieldNames.end());
    all.insert(all.end(), materialFieldNames.begin(), materialFieldNames.end());
    for (std::size_t i = 0; i < all.size(); ++i)
    {
      if (std::find(all.begin() + static_cast<std::ptrdiff_t>(i) + 1, all.end(), all[i]) !=
        all.end())
      {
        vtkErrorMacro(<< FilterName << ": array \"" << all[i]
                      << "\" is selected twice (VolumeFractionArrays, FieldArrays and "
                         "MaterialFieldArrays must name different arrays).");
        return 0;
      }
    }
  }
  auto strings = [](const std::vector<std::string>& list) {
    std::vector<rust::String> out;
    for (const std::string& s : list)
    {
      out.emplace_back(s);
    }
    return out;
  };
  // Material names from the fraction arrays' names, by the bridge.
  std::vector<std::string> materialNames;
  try
  {
    const std::vector<rust::String> fractions = strings(fractionNames);
    for (const rust::String& name :
      bridge::material_names(rust::Slice<const rust::String>(fractions.data(), fractions.size())))
    {
      materialNames.emplace_back(std::string(name));
    }
  }
  catch (const rust::Error& e)
  {
    vtkErrorMacro(<< FilterName << ": " << e.what());
    return 0;
  }
  // The (field, material) of each per-material array, matched by name in the bridge; a <field> that
  // is none of FieldArrays is added after them (a field given only per material).
  const std::size_t numGivenFields = fieldNames.size();
  std::vector<std::array<std::size_t, 2>> materialFieldPairs;
  if (!materialFieldNames.empty())
  {
    const std::vector<rust::String> f = strings(fieldNames);
    const std::vector<rust::String> m = strings(materialNames);
    const std::vector<rust::String> a = strings(materialFieldNames);
    try
    {
      bridge::MaterialFields matched =
        bridge::material_fields(rust::Slice<const rust::String>(f.data(), f.size()),
          rust::Slice<const rust::String>(m.data(), m.size()),
          rust::Slice<const rust::String>(a.data(), a.size()));
      fieldNames.clear();
      for (const rust::String& name : matched.fields)
      {
        fieldNames.emplace_back(std::string(name));
      }
      for (std::size_t i = 0; i + 1 < matched.pairs.size(); i += 2)
      {
        materialFieldPairs.push_back({ matched.pairs[i], matched.pairs[i + 1] });
      }
    }
    catch (const rust::Error& e)
    {
      vtkErrorMacro(<< FilterName << " (MaterialFieldArrays): " << e.what());
      return 0;
    }
    if (materialFieldPairs.size() != materialFieldNames.size() ||
      fieldNames.size() < numGivenFields ||
      std::any_of(materialFieldPairs.begin(), materialFieldPairs.end(),
        [&](const std::array<std::size_t, 2>& p)
        { return p[0] >= fieldNames.size() || p[1] >= materialNames.size(); }))
    {
      vtkErrorMacro(<< "internal error: " << materialFieldPairs.size() << " matches for "
                    << materialFieldNames.size() << " per-material arrays.");
      return 0;
    }
  }
  std::vector<FoundArray> fractions;
  std::vector<FoundArray> fields; // Array == nullptr: a field given only per material
  std::vector<FoundArray> materialFields;
  for (const std::string& name : fractionNames)
  {
    auto found = FindArray(this, input, name, "VolumeFractionArrays");
    if (!found)
    {
      return 0;
    }
    fractions.push_back(*found);
  }
  for (std::size_t f = 0; f < fieldNames.size(); ++f)
  {
    const std::string& name = fieldNames[f];
    const bool inInput = input->GetPointData()->GetArray(name.c_str()) ||
      input->GetCellData()->GetArray(name.c_str());
    const bool perMaterial = std::any_of(materialFieldPairs.begin(), materialFieldPairs.end(),
      [f](const std::array<std::size_t, 2>& p) { return p[0] == f; });
    // Defined by MaterialFieldArrays only, or a FieldArrays name that is no input array.
    if (f >= numGivenFields || (!inInput && perMaterial))
    {
      fields.emplace_back(); // computed from the per-material arrays
      continue;
    }
    auto found = FindArray(this, input, name, "FieldArrays");
    if (!found)
    {
      return 0;
    }
    fields.push_back(*found);
  }
  for (const std::string& name : materialFieldNames)
  {
    auto found = FindArray(this, input, name, "MaterialFieldArrays");
    if (!found)
    {
      return 0;
    }
    materialFields.push_back(*found);
  }

  // ---- The model: kept while its input is the same.
  vtkInternals::ModelKey key;
  for (const auto* list : { &fractions, &fields, &materialFields })
  {
    for (const FoundArray& f : *list)
    {
      key.Arrays.push_back(f.Array);
      key.ArrayMTimes.push_back(f.Array ? f.Array->GetMTime() : 0);
    }
  }
  key.Names = fractionNames;
  key.Names.emplace_back("|");
  key.Names.insert(key.Names.end(), fieldNames.begin(), fieldNames.end());
  key.Names.emplace_back("|");
  key.Names.insert(key.Names.end(), materialFieldNames.begin(), materialFieldNames.end());
  std::copy(grid.dims.begin(), grid.dims.end(), key.Dims.begin());
  std::copy(grid.origin.begin(), grid.origin.end(), key.Origin.begin());
  std::copy(grid.spacing.begin(), grid.spacing.end(), key.Spacing.begin());
  key.Interfaces = interfaceInput;
  key.InterfacesMTime = interfaceInput ? interfaceInput->GetMTime() : 0;
  key.InterfaceMaterialsArray =
    this->InterfaceMaterialsArray ? this->InterfaceMaterialsArray : "";

  this->UpdateProgress(0.0);
  if (!internals.Model || !(internals.BuiltModel == key))
  {
    internals.Release();
    // Cell data to point data, the standard way (average of the cells around each point), for the
    // selected cell arrays only.
    vtkSmartPointer<vtkDataSet> converted;
    bool anyCellData = false;
    for (const auto* list : { &fractions, &fields, &materialFields })
    {
      for (const FoundArray& f : *list)
      {
        anyCellData = anyCellData || f.CellData;
      }
    }
    if (anyCellData)
    {
      vtkSmartPointer<vtkDataSet> shallow =
        vtkSmartPointer<vtkDataSet>::Take(input->NewInstance());
      shallow->ShallowCopy(input);
      vtkNew<vtkCellDataToPointData> c2p;
      c2p->SetInputData(shallow);
      c2p->SetProcessAllArrays(false);
      c2p->PassCellDataOff();
      for (const auto* list : { &fractions, &fields, &materialFields })
      {
        for (const FoundArray& f : *list)
        {
          if (f.Array && f.CellData)
          {
            c2p->AddCellDataArray(f.Array->GetName());
          }
        }
      }
      c2p->Update();
      converted = c2p->GetOutput();
    }
    auto pointValues = [&](const FoundArray& f) -> vtkSmartPointer<vtkFloatArray> {
      vtkDataArray* a = f.Array;
      if (f.CellData)
      {
        a = converted ? converted->GetPointData()->GetArray(f.Array->GetName()) : nullptr;
      }
      return a ? AsFloat(a) : nullptr;
    };

    std::optional<rust::Box<bridge::MaterialBuilder>> builder;
    try
    {
      builder.emplace(bridge::new_material_builder(grid));
      for (std::size_t i = 0; i < fractions.size(); ++i)
      {
        auto values = pointValues(fractions[i]);
        if (!values)
        {
          vtkErrorMacro(<< FilterName << ": cannot convert cell array \"" << fractionNames[i]
                        << "\" to point data.");
          return 0;
        }
        (*builder)->add_fraction(SliceOf(values));
      }
      for (std::size_t i = 0; i < fields.size(); ++i)
      {
        if (!fields[i].Array)
        {
          (*builder)->add_field_from_materials();
          continue;
        }
        auto values = pointValues(fields[i]);
        if (!values)
        {
          vtkErrorMacro(<< FilterName << ": cannot convert cell array \"" << fieldNames[i]
                        << "\" to point data.");
          return 0;
        }
        (*builder)->add_field(SliceOf(values));
      }
      for (std::size_t i = 0; i < materialFields.size(); ++i)
      {
        auto values = pointValues(materialFields[i]);
        if (!values)
        {
          vtkErrorMacro(<< FilterName << ": cannot convert cell array \""
                        << materialFieldNames[i] << "\" to point data.");
          return 0;
        }
        (*builder)->add_material_field(
          materialFieldPairs[i][0], materialFieldPairs[i][1], SliceOf(values));
      }
    }
    catch (const rust::Error& e)
    {
      vtkErrorMacro(<< FilterName << " cannot process this input: " << e.what());
      return 0;
    }

    // The user's interface meshes (input 1): triangles with a material pair each.
    if (interfaceInput && interfaceInput->GetNumberOfCells() > 0)
    {
      const char* pairName = this->InterfaceMaterialsArray ? this->InterfaceMaterialsArray : "";
      vtkDataArray* pairs = interfaceInput->GetCellData()->GetArray(pairName);
      if (!pairs || pairs->GetNumberOfComponents() != 2)
      {
        vtkErrorMacro(<< FilterName << ": the interface meshes (input 1) need a 2-component "
                      << "cell array \"" << pairName
                      << "\" naming the two materials of each triangle (indices into "
                         "VolumeFractionArrays). Cell arrays: "
                      << vtkDiamonds::ArrayNames(interfaceInput->GetCellData()) << ".");
        return 0;
      }
      if (interfaceInput->GetNumberOfVerts() + interfaceInput->GetNumberOfLines() +
          interfaceInput->GetNumberOfStrips() >
        0)
      {
        vtkErrorMacro(<< FilterName << ": the interface meshes (input 1) must hold triangles "
                                       "only (apply Triangulate; no vertices, lines or strips).");
        return 0;
      }
      const vtkIdType numPoints = interfaceInput->GetNumberOfPoints();
      const vtkIdType numCells = interfaceInput->GetNumberOfCells();
      std::vector<double> xyz(static_cast<std::size_t>(3 * numPoints));
      for (vtkIdType p = 0; p < numPoints; ++p)
      {
        interfaceInput->GetPoint(p, &xyz[static_cast<std::size_t>(3 * p)]);
      }
      std::vector<std::uint32_t> triangles;
      std::vector<std::int64_t> pairValues;
      triangles.reserve(static_cast<std::size_t>(3 * numCells));
      pairValues.reserve(static_cast<std::size_t>(2 * numCells));
      vtkCellArray* polys = interfaceInput->GetPolys();
      vtkIdType cell = 0;
      vtkIdType npts = 0;
      const vtkIdType* pts = nullptr;
      for (polys->InitTraversal(); polys->GetNextCell(npts, pts); ++cell)
      {
        if (npts != 3)
        {
          vtkErrorMacro(<< FilterName << ": interface mesh cell " << cell << " has " << npts
                        << " points; only triangles are read (apply Triangulate first).");
          return 0;
        }
        for (int c = 0; c < 3; ++c)
        {
          triangles.push_back(static_cast<std::uint32_t>(pts[c]));
        }
        for (int c = 0; c < 2; ++c)
        {
          const double v = pairs->GetComponent(cell, c);
          pairValues.push_back(std::isfinite(v) && std::abs(v) < 1e9
              ? static_cast<std::int64_t>(std::llround(v))
              : std::int64_t(-1));
        }
      }
      std::vector<double> normals;
      bool pointNormals = false;
      vtkDataArray* n = interfaceInput->GetCellData()->GetNormals();
      if (!n)
      {
        n = interfaceInput->GetPointData()->GetNormals();
        pointNormals = n != nullptr;
      }
      if (n && n->GetNumberOfComponents() == 3)
      {
        normals.resize(static_cast<std::size_t>(3 * n->GetNumberOfTuples()));
        for (vtkIdType t = 0; t < n->GetNumberOfTuples(); ++t)
        {
          n->GetTuple(t, &normals[static_cast<std::size_t>(3 * t)]);
        }
      }
      try
      {
        (*builder)->set_interfaces(rust::Slice<const double>(xyz.data(), xyz.size()),
          rust::Slice<const std::uint32_t>(triangles.data(), triangles.size()),
          rust::Slice<const std::int64_t>(pairValues.data(), pairValues.size()),
          rust::Slice<const double>(normals.data(), normals.size()), pointNormals);
      }
      catch (const rust::Error& e)
      {
        vtkErrorMacro(<< FilterName << " cannot use the interface meshes (input 1): " << e.what());
        return 0;
      }
    }

    try
    {
      internals.Model.emplace((*builder)->build());
    }
    catch (const rust::Error& e)
    {
      vtkErrorMacro(<< FilterName << " cannot process this input: " << e.what());
      return 0;
    }
    internals.BuiltModel = key;
    ++this->NumberOfModelBuilds;
  }
  this->UpdateProgress(0.3);
  if (this->CheckAbort())
  {
    return 1;
  }

  // ---- The mesh: kept while the query is the same.
  vtkInternals::MeshKey meshKey;
  meshKey.InterfaceTolerance = this->InterfaceTolerance;
  // Without fields the field tolerance is irrelevant: changing it keeps the mesh.
  meshKey.FieldTolerance = fields.empty() ? 0.0 : this->FieldTolerance;
  meshKey.GhostValues = this->UseGhostValues != 0;
  if (!internals.Mesh || !(internals.BuiltMesh == meshKey))
  {
    internals.Mesh.reset();
    bridge::MaterialQuerySpec query;
    query.interface_tolerance = meshKey.InterfaceTolerance;
    query.field_tolerance = meshKey.FieldTolerance;
    query.ghost_values = meshKey.GhostValues;
    vtkDiamonds::ProgressForwarder progress(this, 0.3, 0.85);
    try
    {
      internals.Mesh.emplace((**internals.Model).refine(query, progress));
      const bridge::MaterialMesh& refined = **internals.Mesh;
      if (refined.max_interface_error() > meshKey.InterfaceTolerance ||
        refined.max_field_error() > meshKey.FieldTolerance)
      {
        vtkWarningMacro(<< FilterName << ": the finest tetrahedra (half a cell wide) cannot meet the "
                        << "tolerances everywhere; reached interface error "
                        << refined.max_interface_error() << " and field error "
                        << refined.max_field_error()
                        << " (see MaximumInterfaceError, MaximumFieldError and the cell arrays). Samples "
                        << "are mesh vertices only with 2^k + 1 points per axis.");
      }
    }
    catch (const rust::Error& e)
    {
      if (progress.Aborted)
      {
        vtkDebugMacro(<< "Refinement aborted.");
        return 1;
      }
      vtkErrorMacro(<< FilterName << " refinement failed: " << e.what());
      return 0;
    }
    internals.BuiltMesh = meshKey;
    ++this->NumberOfRefinements;
  }
  this->UpdateProgress(0.85);
  if (this->CheckAbort())
  {
    return 1;
  }
  const bridge::MaterialMesh& mesh = **internals.Mesh;

  // ---- Names.
  std::vector<std::string> interfaceNames;

  // ---- Output 0: the tetrahedra.
  try
  {
    const std::size_t numMaterials = mesh.number_of_materials();
    const std::size_t numFields = mesh.number_of_fields();
    const std::size_t numPairs = mesh.number_of_pairs();
    if (numMaterials != materialNames.size() || numFields != fieldNames.size())
    {
      vtkErrorMacro(<< "internal error: the mesh has " << numMaterials << " materials and "
                    << numFields << " fields for " << materialNames.size() << " and "
                    << fieldNames.size() << " arrays.");
      return 0;
    }
    rust::Slice<const double> xyz = mesh.points();
    rust::Slice<const std::uint32_t> tets = mesh.tets();
    const vtkIdType numPoints = static_cast<vtkIdType>(xyz.size() / 3);
    const vtkIdType numTets = static_cast<vtkIdType>(tets.size() / 4);
    tetOutput->SetPoints(PointsFrom(xyz));
    tetOutput->SetCells(VTK_TETRA, FixedSizeCells(4, tets, numPoints));

    vtkPointData* pd = tetOutput->GetPointData();
    rust::Slice<const std::uint8_t> pointMaterial = mesh.point_material();
    vtkNew<vtkIntArray> material;
    material->SetName("Material");
    material->SetNumberOfValues(numPoints);
    std::copy(pointMaterial.begin(), pointMaterial.end(), material->GetPointer(0));
    pd->AddArray(material);
    pd->SetActiveScalars("Material");

    rust::Slice<const std::uint8_t> pairs = mesh.pairs();
    for (std::size_t i = 0; i < numPairs; ++i)
    {
      const std::string name = materialNames[pairs[2 * i]] + "|" + materialNames[pairs[2 * i + 1]];
      interfaceNames.push_back(name);
      rust::Slice<const float> d = mesh.interface_distance(i);
      pd->AddArray(
        NamedArray<vtkFloatArray>(("SignedDistance " + name).c_str(), numPoints, d.data()));
    }
    for (std::size_t m = 0; m < numMaterials; ++m)
    {
      rust::Slice<const float> d = mesh.material_distance(m);
      pd->AddArray(NamedArray<vtkFloatArray>(
        ("SignedDistance " + materialNames[m]).c_str(), numPoints, d.data()));
    }
    const bool perMaterial = mesh.has_material_fields();
    for (std::size_t f = 0; f < numFields; ++f)
    {
      rust::Slice<const float> mixed = mesh.mixed_field(f);
      pd->AddArray(NamedArray<vtkFloatArray>(fieldNames[f].c_str(), numPoints, mixed.data()));
      if (perMaterial)
      {
        for (std::size_t m = 0; m < numMaterials; ++m)
        {
          rust::Slice<const float> v = mesh.material_field(f, m);
          pd->AddArray(NamedArray<vtkFloatArray>(
            (fieldNames[f] + " (" + materialNames[m] + ")").c_str(), numPoints, v.data()));
        }
      }
    }
    if (perMaterial)
    {
      for (std::size_t m = 0; m < numMaterials; ++m)
      {
        vtkNew<vtkUnsignedCharArray> ghost;
        ghost->SetName(("IsGhost (" + materialNames[m] + ")").c_str());
        ghost->SetNumberOfValues(numPoints);
        for (vtkIdType p = 0; p < numPoints; ++p)
        {
          ghost->SetValue(p, pointMaterial[static_cast<std::size_t>(p)] != m ? 1 : 0);
        }
        pd->AddArray(ghost);
      }
    }

    vtkCellData* cd = tetOutput->GetCellData();
    rust::Slice<const float> interfaceError = mesh.interface_error();
    rust::Slice<const float> fieldError = mesh.field_error();
    rust::Slice<const std::uint32_t> tetMaterials = mesh.tet_materials();
    rust::Slice<const std::uint8_t> levels = mesh.levels();
    cd->AddArray(NamedArray<vtkFloatArray>("InterfaceError", numTets, interfaceError.data()));
    cd->AddArray(NamedArray<vtkFloatArray>("FieldError", numTets, fieldError.data()));
    cd->AddArray(NamedArray<vtkTypeUInt32Array>("Materials", numTets, tetMaterials.data()));
    vtkNew<vtkUnsignedCharArray> count;
    count->SetName("NumberOfMaterials");
    count->SetNumberOfValues(numTets);
    for (vtkIdType t = 0; t < numTets; ++t)
    {
      count->SetValue(t,
        static_cast<unsigned char>(std::bitset<32>(tetMaterials[static_cast<std::size_t>(t)]).count()));
    }
    cd->AddArray(count);
    cd->AddArray(NamedArray<vtkUnsignedCharArray>("Level", numTets, levels.data()));

    vtkFieldData* fd = tetOutput->GetFieldData();
    fd->PassData(input->GetFieldData());
    fd->AddArray(OneValue<vtkDoubleArray>("InterfaceTolerance", this->InterfaceTolerance));
    fd->AddArray(OneValue<vtkDoubleArray>("FieldTolerance", this->FieldTolerance));
    fd->AddArray(OneValue<vtkDoubleArray>("MaximumInterfaceError", mesh.max_interface_error()));
    fd->AddArray(OneValue<vtkDoubleArray>("MaximumFieldError", mesh.max_field_error()));
    fd->AddArray(OneValue<vtkIdTypeArray>("NumberOfTetrahedra", numTets));
    fd->AddArray(OneValue<vtkIdTypeArray>(
      "InterfaceTetrahedra", static_cast<vtkIdType>(mesh.interface_tetrahedra())));
    fd->AddArray(OneValue<vtkIntArray>("UseGhostValues", this->UseGhostValues ? 1 : 0));
    fd->AddArray(Strings("MaterialNames", materialNames));
    fd->AddArray(Strings("InterfaceNames", interfaceNames));
    fd->AddArray(Strings("FieldNames", fieldNames));

    // ---- Output 1: the approximated interfaces.
    rust::Box<bridge::PolygonMesh> polygons = mesh.interface_polygons();
    interfaceOutput->SetPoints(PointsFrom(polygons->points()));
    interfaceOutput->SetPolys(CellsFrom(polygons->offsets(), polygons->connectivity()));
    rust::Slice<const std::uint8_t> labels = polygons->labels();
    const vtkIdType numPolygons = static_cast<vtkIdType>(polygons->number_of_polygons());
    vtkNew<vtkIntArray> interfaceIndex;
    interfaceIndex->SetName("Interface");
    interfaceIndex->SetNumberOfValues(numPolygons);
    vtkNew<vtkIntArray> materialA;
    materialA->SetName("MaterialA");
    materialA->SetNumberOfValues(numPolygons);
    vtkNew<vtkIntArray> materialB;
    materialB->SetName("MaterialB");
    materialB->SetNumberOfValues(numPolygons);
    for (vtkIdType p = 0; p < numPolygons; ++p)
    {
      const int a = labels[static_cast<std::size_t>(2 * p)];
      const int b = labels[static_cast<std::size_t>(2 * p + 1)];
      int index = -1;
      for (std::size_t i = 0; i < numPairs; ++i)
      {
        if (pairs[2 * i] == a && pairs[2 * i + 1] == b)
        {
          index = static_cast<int>(i);
          break;
        }
      }
      interfaceIndex->SetValue(p, index);
      materialA->SetValue(p, a);
      materialB->SetValue(p, b);
    }
    interfaceOutput->GetCellData()->AddArray(interfaceIndex);
    interfaceOutput->GetCellData()->AddArray(materialA);
    interfaceOutput->GetCellData()->AddArray(materialB);
    interfaceOutput->GetCellData()->SetActiveScalars("Interface");
    interfaceOutput->GetFieldData()->AddArray(Strings("MaterialNames", materialNames));
    interfaceOutput->GetFieldData()->AddArray(Strings("InterfaceNames", interfaceNames));
    interfaceOutput->GetFieldData()->AddArray(
      OneValue<vtkIdTypeArray>("NumberOfPolygons", numPolygons));

    // ---- Output 2: the slice.
    bridge::PlaneSpec plane;
    std::copy(this->SliceOrigin, this->SliceOrigin + 3, plane.origin.begin());
    std::copy(this->SliceNormal, this->SliceNormal + 3, plane.normal.begin());
    rust::Box<bridge::PolygonMesh> slice = mesh.slice(plane);
    sliceOutput->SetPoints(PointsFrom(slice->points()));
    sliceOutput->SetPolys(CellsFrom(slice->offsets(), slice->connectivity()));
    rust::Slice<const std::uint8_t> sliceLabels = slice->labels();
    const vtkIdType numSlicePolygons = static_cast<vtkIdType>(slice->number_of_polygons());
    vtkNew<vtkIntArray> sliceMaterial;
    sliceMaterial->SetName("Material");
    sliceMaterial->SetNumberOfValues(numSlicePolygons);
    for (vtkIdType p = 0; p < numSlicePolygons; ++p)
    {
      const int m = sliceLabels[static_cast<std::size_t>(2 * p)];
      sliceMaterial->SetValue(p, m == 255 ? -1 : m);
    }
    sliceOutput->GetCellData()->AddArray(sliceMaterial);
    sliceOutput->GetCellData()->SetActiveScalars("Material");
    const vtkIdType numSlicePoints = static_cast<vtkIdType>(slice->points().size() / 3);
    const std::size_t numValues = slice->number_of_value_arrays();
    for (std::size_t f = 0; f < numValues && f < fieldNames.size(); ++f)
    {
      rust::Slice<const float> v = slice->values(f);
      sliceOutput->GetPointData()->AddArray(
        NamedArray<vtkFloatArray>(fieldNames[f].c_str(), numSlicePoints, v.data()));
    }
    sliceOutput->GetFieldData()->AddArray(Strings("MaterialNames", materialNames));
    vtkNew<vtkDoubleArray> planeArray;
    planeArray->SetName("SlicePlane");
    planeArray->SetNumberOfComponents(6);
    planeArray->InsertNextTuple6(plane.origin[0], plane.origin[1], plane.origin[2],
      plane.normal[0], plane.normal[1], plane.normal[2]);
    sliceOutput->GetFieldData()->AddArray(planeArray);
  }
  catch (const rust::Error& e)
  {
    vtkErrorMacro(<< FilterName << ": " << e.what());
    tetOutput->Initialize();
    interfaceOutput->Initialize();
    sliceOutput->Initialize();
    return 0;
  }

  this->UpdateProgress(1.0);
  return 1;
}

//------------------------------------------------------------------------------
void vtkMaterialInterfaceApproximation::PrintSelf(ostream& os, vtkIndent indent)
{
  this->Superclass::PrintSelf(os, indent);
  os << indent << "VolumeFractionArrays:";
  for (const std::string& n : this->Internals->FractionArrays)
  {
    os << " \"" << n << "\"";
  }
  os << "\n" << indent << "FieldArrays:";
  for (const std::string& n : this->Internals->FieldArrays)
  {
    os << " \"" << n << "\"";
  }
  os << "\n" << indent << "MaterialFieldArrays:";
  for (const std::string& n : this->Internals->MaterialFieldArrays)
  {
    os << " \"" << n << "\"";
  }
  os << "\n";
  os << indent << "InterfaceTolerance: " << this->InterfaceTolerance << "\n";
  os << indent << "FieldTolerance: " << this->FieldTolerance << "\n";
  os << indent << "UseGhostValues: " << (this->UseGhostValues ? "On" : "Off") << "\n";
  os << indent << "SliceOrigin: (" << this->SliceOrigin[0] << ", " << this->SliceOrigin[1] << ", "
     << this->SliceOrigin[2] << ")\n";
  os << indent << "SliceNormal: (" << this->SliceNormal[0] << ", " << this->SliceNormal[1] << ", "
     << this->SliceNormal[2] << ")\n";
  os << indent << "InterfaceMaterialsArray: "
     << (this->InterfaceMaterialsArray ? this->InterfaceMaterialsArray : "(none)") << "\n";
  os << indent << "NumberOfModelBuilds: " << this->NumberOfModelBuilds << "\n";
  os << indent << "NumberOfRefinements: " << this->NumberOfRefinements << "\n";
}
