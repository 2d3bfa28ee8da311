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
#include "vtkObjectFactory.h"
#include "vtkPointData.h"
#include "vtkPolyData.h"
#include "vtkRectilinearGrid.h"
#include "vtkSmartPointer.h"
#include "vtkStreamingDemandDrivenPipeline.h"
#include "vtkStringArray.h"
#include "vtkUnstructuredGrid.h"

// The module's internal helpers and the cxx bridge. Kept out of the public header: the VTK
// wrappers parse it.
#include "vtkDiamondsArraySelection.h"
#include "vtkDiamondsImageGeometry.h"
#include "vtkDiamondsOutput.h"
#include "vtkDiamondsPieces.h"
#include "vtkDiamondsProgress.h"

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

vtkStandardNewMacro(vtkMaterialInterfaceApproximation);

namespace
{
namespace bridge = diamonds::bridge;
using vtkDiamonds::AddOutputArrays;
using vtkDiamonds::CellsFrom;
using vtkDiamonds::FixedSizeCells;
using vtkDiamonds::PointsFrom;
using vtkDiamonds::Strings;

const char* const FilterName = "Material Interface Approximation";

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

template <typename T>
rust::Slice<const T> SliceOf(const std::vector<T>& v)
{
  return rust::Slice<const T>(v.data(), v.size());
}

std::vector<rust::String> RustStrings(const std::vector<std::string>& list)
{
  return std::vector<rust::String>(list.begin(), list.end());
}

// The input's array the selection names (nullptr for a field computed from per-material arrays).
vtkDataArray* ArrayOf(vtkDataSet* input, const bridge::SelectedArray& a)
{
  vtkFieldData* data = a.cell ? static_cast<vtkFieldData*>(input->GetCellData())
                              : static_cast<vtkFieldData*>(input->GetPointData());
  return data->GetArray(std::string(a.name).c_str());
}

// The uniform grid of an image or a uniformly spaced rectilinear grid; reports an error otherwise.
std::optional<bridge::GridSpec> GridOf(vtkAlgorithm* filter, vtkDataSet* input)
{
  bridge::GridSpec grid;
  if (auto* image = vtkImageData::SafeDownCast(input))
  {
    if (!vtkDiamonds::IsAxisAligned(image))
    {
      vtkErrorWithObjectMacro(filter,
        << FilterName
        << ": the input image is oriented (its direction matrix is not the identity); only "
           "axis-aligned images are supported. Apply Resample To Image first.");
      return std::nullopt;
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
    return grid;
  }
  auto* rectilinear = vtkRectilinearGrid::SafeDownCast(input);
  if (!rectilinear)
  {
    vtkErrorWithObjectMacro(filter,
      << FilterName << " needs a vtkImageData or vtkRectilinearGrid input, not a "
      << input->GetClassName() << ".");
    return std::nullopt;
  }
  std::vector<double> coords[3];
  vtkDataArray* arrays[3] = { rectilinear->GetXCoordinates(), rectilinear->GetYCoordinates(),
    rectilinear->GetZCoordinates() };
  for (int axis = 0; axis < 3; ++axis)
  {
    const vtkIdType n = arrays[axis] ? arrays[axis]->GetNumberOfTuples() : 0;
    for (vtkIdType i = 0; i < n; ++i)
    {
      coords[axis].push_back(arrays[axis]->GetComponent(i, 0));
    }
  }
  try
  {
    return bridge::grid_from_coordinates(SliceOf(coords[0]), SliceOf(coords[1]), SliceOf(coords[2]));
  }
  catch (const rust::Error& e)
  {
    vtkErrorWithObjectMacro(
      filter, << FilterName << " cannot use this rectilinear grid: " << e.what());
    return std::nullopt;
  }
}

// The user's interface meshes (input 1) as a triangle soup with a material pair per triangle, set
// on `builder`; reports an error and returns false when they cannot be read.
bool SetInterfaces(vtkAlgorithm* filter, bridge::MaterialBuilder& builder, vtkPolyData* meshes,
  const char* pairArray)
{
  const char* pairName = pairArray ? pairArray : "";
  vtkDataArray* pairs = meshes->GetCellData()->GetArray(pairName);
  if (!pairs || pairs->GetNumberOfComponents() != 2)
  {
    vtkErrorWithObjectMacro(filter,
      << FilterName << ": the interface meshes (input 1) need a 2-component cell array \""
      << pairName
      << "\" naming the two materials of each triangle (indices into VolumeFractionArrays). "
         "Cell arrays: "
      << vtkDiamonds::ArrayNames(meshes->GetCellData()) << ".");
    return false;
  }
  if (meshes->GetNumberOfVerts() + meshes->GetNumberOfLines() + meshes->GetNumberOfStrips() > 0)
  {
    vtkErrorWithObjectMacro(filter,
      << FilterName
      << ": the interface meshes (input 1) must hold triangles only (apply Triangulate; no "
         "vertices, lines or strips).");
    return false;
  }
  std::vector<double> xyz(static_cast<std::size_t>(3 * meshes->GetNumberOfPoints()));
  for (vtkIdType p = 0; p < meshes->GetNumberOfPoints(); ++p)
  {
    meshes->GetPoint(p, &xyz[static_cast<std::size_t>(3 * p)]);
  }
  std::vector<std::uint32_t> triangles;
  std::vector<std::int64_t> pairValues;
  vtkCellArray* polys = meshes->GetPolys();
  vtkIdType cell = 0;
  vtkIdType npts = 0;
  const vtkIdType* pts = nullptr;
  for (polys->InitTraversal(); polys->GetNextCell(npts, pts); ++cell)
  {
    if (npts != 3)
    {
      vtkErrorWithObjectMacro(filter,
        << FilterName << ": interface mesh cell " << cell << " has " << npts
        << " points; only triangles are read (apply Triangulate first).");
      return false;
    }
    triangles.insert(triangles.end(), pts, pts + 3);
    for (int c = 0; c < 2; ++c)
    {
      const double v = pairs->GetComponent(cell, c);
      pairValues.push_back(std::isfinite(v) && std::abs(v) < 1e9
          ? static_cast<std::int64_t>(std::llround(v))
          : std::int64_t(-1));
    }
  }
  std::vector<double> normals;
  vtkDataArray* n = meshes->GetCellData()->GetNormals();
  const bool pointNormals = !n && meshes->GetPointData()->GetNormals();
  if (pointNormals)
  {
    n = meshes->GetPointData()->GetNormals();
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
    builder.set_interfaces(
      SliceOf(xyz), SliceOf(triangles), SliceOf(pairValues), SliceOf(normals), pointNormals);
  }
  catch (const rust::Error& e)
  {
    vtkErrorWithObjectMacro(
      filter, << FilterName << " cannot use the interface meshes (input 1): " << e.what());
    return false;
  }
  return true;
}
} // namespace

class vtkMaterialInterfaceApproximation::vtkInternals
{
public:
  // Clears a stale abort (see AbortLatch).
  vtkDiamonds::AbortLatch Abort;
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

  // What the model, the mesh or the outputs step reports.
  enum class Status
  {
    Done,
    Aborted,
    Failed
  };

  std::optional<rust::Box<bridge::MaterialModel>> Model;
  ModelKey BuiltModel;
  std::optional<rust::Box<bridge::MaterialMesh>> Mesh;
  MeshKey BuiltMesh;

  // The selection of the current execution: material and field names.
  std::vector<rust::String> Materials;
  std::vector<rust::String> Fields;

  void Release()
  {
    this->Mesh.reset();
    this->Model.reset();
    this->BuiltModel = ModelKey{};
  }

  // The tolerances and the slice plane are finite, the tolerances >= 0.
  bool CheckParameters(vtkMaterialInterfaceApproximation* self);
  // The arrays to read, chosen by the core from the selected names and the input's arrays.
  std::optional<bridge::ArraySelection> SelectArrays(
    vtkMaterialInterfaceApproximation* self, vtkDataSet* input);
  // Builds the model unless the kept one was built from the same arrays, grid and meshes.
  Status UpdateModel(vtkMaterialInterfaceApproximation* self, vtkDataSet* input,
    vtkPolyData* interfaces, const bridge::GridSpec& grid, const bridge::ArraySelection& selection);
  // Refines the model unless the kept mesh was refined for the same query.
  Status UpdateMesh(vtkMaterialInterfaceApproximation* self, bool withFields);
  // The grid, the arrays, the model and the mesh of `input` (progress 0 to 0.85); `grid` receives
  // the input's grid.
  Status Update(vtkMaterialInterfaceApproximation* self, vtkDataSet* input,
    vtkPolyData* interfaces, bridge::GridSpec& grid);
  // The slice plane of the current execution.
  bridge::PlaneSpec Plane(vtkMaterialInterfaceApproximation* self) const;
  // The three outputs from a mesh or polygons (the kept mesh's, or under MPI this rank's share,
  // whose points then get "GlobalPointIds").
  void FillTetrahedra(vtkMaterialInterfaceApproximation* self, vtkDataSet* input,
    const bridge::MaterialMesh& mesh, vtkUnstructuredGrid* output, bool share);
  void FillInterfaces(const bridge::PolygonMesh& polygons, vtkPolyData* output, bool share);
  void FillSlice(const bridge::PolygonMesh& polygons, vtkPolyData* output, bool share);

  // Under MPI (more than one rank): every rank with a piece puts the whole input together
  // (Pieces::GatherWhole), computes the serial approximation and outputs its share of each port
  // (the cells whose centroid its half-open cell box holds).
  int RequestDistributed(vtkMaterialInterfaceApproximation* self,
    vtkMultiProcessController* controller, vtkInformationVector** inputVector, vtkDataSet* input,
    vtkPolyData* interfaces, vtkUnstructuredGrid* tetOutput, vtkPolyData* interfaceOutput,
    vtkPolyData* sliceOutput);
  // What the whole input was put together from: the gathered arrays (and a rectilinear grid's
  // coordinates) with their modification times, every rank's extent, an image's geometry.
  struct WholeKey
  {
    std::vector<const void*> Arrays;
    std::vector<vtkMTimeType> MTimes;
    std::vector<std::int64_t> Extents;
    std::array<double, 6> Geometry{};
    bool operator==(const WholeKey& o) const
    {
      return this->Arrays == o.Arrays && this->MTimes == o.MTimes && this->Extents == o.Extents &&
        this->Geometry == o.Geometry;
    }
  };
  vtkSmartPointer<vtkDataSet> Whole;
  WholeKey WholeBuilt;

private:
  template <typename List>
  static std::vector<std::string> StdStrings(const List& list)
  {
    std::vector<std::string> out;
    for (const rust::String& s : list)
    {
      out.emplace_back(std::string(s));
    }
    return out;
  }
  rust::Slice<const rust::String> MaterialNames() const { return SliceOf(this->Materials); }
  rust::Slice<const rust::String> FieldNames() const { return SliceOf(this->Fields); }
};

//------------------------------------------------------------------------------
std::optional<bridge::ArraySelection> vtkMaterialInterfaceApproximation::vtkInternals::SelectArrays(
  vtkMaterialInterfaceApproximation* self, vtkDataSet* input)
{
  std::vector<bridge::InputArrayInfo> listing;
  for (vtkFieldData* data : { static_cast<vtkFieldData*>(input->GetPointData()),
         static_cast<vtkFieldData*>(input->GetCellData()) })
  {
    for (int i = 0; i < data->GetNumberOfArrays(); ++i)
    {
      vtkDataArray* a = data->GetArray(i);
      if (a && a->GetName())
      {
        listing.push_back({ a->GetName(), static_cast<std::size_t>(a->GetNumberOfComponents()),
          data == input->GetCellData() });
      }
    }
  }
  const std::vector<rust::String> fractions = RustStrings(this->FractionArrays);
  const std::vector<rust::String> fields = RustStrings(this->FieldArrays);
  const std::vector<rust::String> materialFields = RustStrings(this->MaterialFieldArrays);
  try
  {
    bridge::ArraySelection selection = bridge::select_material_arrays(
      SliceOf(listing), SliceOf(fractions), SliceOf(fields), SliceOf(materialFields));
    this->Materials.assign(selection.materials.begin(), selection.materials.end());
    this->Fields.clear();
    for (const bridge::SelectedField& f : selection.fields)
    {
      this->Fields.push_back(f.name);
    }
    return selection;
  }
  catch (const rust::Error& e)
  {
    vtkErrorWithObjectMacro(self, << FilterName << ": " << e.what());
    return std::nullopt;
  }
}

//------------------------------------------------------------------------------
vtkMaterialInterfaceApproximation::vtkInternals::Status
vtkMaterialInterfaceApproximation::vtkInternals::UpdateModel(vtkMaterialInterfaceApproximation* self,
  vtkDataSet* input, vtkPolyData* interfaces, const bridge::GridSpec& grid,
  const bridge::ArraySelection& selection)
{
  // Every selected array in order (nullptr: a field computed from per-material arrays), and
  // whether it is cell data.
  std::vector<std::pair<vtkDataArray*, bool>> arrays;
  ModelKey key;
  for (const bridge::SelectedArray& a : selection.fractions)
  {
    arrays.emplace_back(ArrayOf(input, a), a.cell);
    key.Names.emplace_back(std::string(a.name));
  }
  key.Names.emplace_back("|");
  for (const bridge::SelectedField& f : selection.fields)
  {
    arrays.emplace_back(f.from_materials ? nullptr : ArrayOf(input, f.array), f.array.cell);
    key.Names.emplace_back(std::string(f.name));
  }
  key.Names.emplace_back("|");
  for (const bridge::SelectedMaterialField& m : selection.material_fields)
  {
    arrays.emplace_back(ArrayOf(input, m.array), m.array.cell);
    key.Names.emplace_back(std::string(m.array.name));
  }
  for (const auto& a : arrays)
  {
    key.Arrays.push_back(a.first);
    key.ArrayMTimes.push_back(a.first ? a.first->GetMTime() : 0);
  }
  std::copy(grid.dims.begin(), grid.dims.end(), key.Dims.begin());
  std::copy(grid.origin.begin(), grid.origin.end(), key.Origin.begin());
  std::copy(grid.spacing.begin(), grid.spacing.end(), key.Spacing.begin());
  key.Interfaces = interfaces;
  key.InterfacesMTime = interfaces ? interfaces->GetMTime() : 0;
  key.InterfaceMaterialsArray =
    self->InterfaceMaterialsArray ? self->InterfaceMaterialsArray : "";
  if (this->Model && this->BuiltModel == key)
  {
    return Status::Done;
  }
  this->Release();

  // Cell data to point data, the standard way (average of the cells around each point), for the
  // selected cell arrays only.
  vtkNew<vtkCellDataToPointData> c2p;
  c2p->SetProcessAllArrays(false);
  c2p->PassCellDataOff();
  bool anyCellData = false;
  for (const auto& a : arrays)
  {
    if (a.first && a.second)
    {
      c2p->AddCellDataArray(a.first->GetName());
      anyCellData = true;
    }
  }
  vtkSmartPointer<vtkDataSet> converted;
  if (anyCellData)
  {
    vtkSmartPointer<vtkDataSet> shallow = vtkSmartPointer<vtkDataSet>::Take(input->NewInstance());
    shallow->ShallowCopy(input);
    c2p->SetInputData(shallow);
    c2p->Update();
    converted = c2p->GetOutput();
  }
  // The point values of every selected array as floats (empty for computed fields).
  std::vector<vtkSmartPointer<vtkFloatArray>> values;
  for (const auto& a : arrays)
  {
    vtkDataArray* points = a.first;
    if (a.first && a.second)
    {
      points = converted ? converted->GetPointData()->GetArray(a.first->GetName()) : nullptr;
      if (!points)
      {
        vtkErrorWithObjectMacro(self,
          << FilterName << ": cannot convert cell array \"" << a.first->GetName()
          << "\" to point data.");
        return Status::Failed;
      }
    }
    values.push_back(points ? AsFloat(points) : nullptr);
  }

  std::optional<rust::Box<bridge::MaterialBuilder>> builder;
  try
  {
    builder.emplace(bridge::new_material_builder(grid));
    std::size_t i = 0;
    for (; i < selection.fractions.size(); ++i)
    {
      (*builder)->add_fraction(SliceOf(values[i]));
    }
    for (const bridge::SelectedField& f : selection.fields)
    {
      if (f.from_materials)
      {
        (*builder)->add_field_from_materials(f.name);
      }
      else
      {
        (*builder)->add_field(f.name, SliceOf(values[i]));
      }
      ++i;
    }
    for (const bridge::SelectedMaterialField& m : selection.material_fields)
    {
      (*builder)->add_material_field(m.field, m.material, SliceOf(values[i++]));
    }
  }
  catch (const rust::Error& e)
  {
    vtkErrorWithObjectMacro(self, << FilterName << " cannot process this input: " << e.what());
    return Status::Failed;
  }
  if (interfaces && interfaces->GetNumberOfCells() > 0 &&
    !SetInterfaces(self, **builder, interfaces, self->InterfaceMaterialsArray))
  {
    return Status::Failed;
  }
  try
  {
    this->Model.emplace((*builder)->build());
  }
  catch (const rust::Error& e)
  {
    vtkErrorWithObjectMacro(self, << FilterName << " cannot process this input: " << e.what());
    return Status::Failed;
  }
  this->BuiltModel = key;
  ++self->NumberOfModelBuilds;
  return Status::Done;
}

//------------------------------------------------------------------------------
bool vtkMaterialInterfaceApproximation::vtkInternals::CheckParameters(
  vtkMaterialInterfaceApproximation* self)
{
  for (const auto& t : { std::make_pair("InterfaceTolerance", self->InterfaceTolerance),
         std::make_pair("FieldTolerance", self->FieldTolerance) })
  {
    if (!std::isfinite(t.second) || t.second < 0.0)
    {
      vtkErrorWithObjectMacro(self,
        << FilterName << ": " << t.first << " must be a finite number >= 0 (got " << t.second
        << ").");
      return false;
    }
  }
  for (int axis = 0; axis < 3; ++axis)
  {
    if (!std::isfinite(self->SliceOrigin[axis]) || !std::isfinite(self->SliceNormal[axis]))
    {
      vtkErrorWithObjectMacro(
        self, << FilterName << ": SliceOrigin and SliceNormal must be finite.");
      return false;
    }
  }
  return true;
}


//------------------------------------------------------------------------------
vtkMaterialInterfaceApproximation::vtkInternals::Status
vtkMaterialInterfaceApproximation::vtkInternals::UpdateMesh(
  vtkMaterialInterfaceApproximation* self, bool withFields)
{
  MeshKey key;
  key.InterfaceTolerance = self->InterfaceTolerance;
  // Without fields the field tolerance is irrelevant: changing it keeps the mesh.
  key.FieldTolerance = withFields ? self->FieldTolerance : 0.0;
  key.GhostValues = self->UseGhostValues != 0;
  if (this->Mesh && this->BuiltMesh == key)
  {
    return Status::Done;
  }
  this->Mesh.reset();
  bridge::MaterialQuerySpec query;
  query.interface_tolerance = key.InterfaceTolerance;
  query.field_tolerance = key.FieldTolerance;
  query.ghost_values = key.GhostValues;
  vtkDiamonds::ProgressForwarder progress(self, 0.3, 0.85);
  try
  {
    this->Mesh.emplace((**this->Model).refine(query, progress));
  }
  catch (const rust::Error& e)
  {
    if (progress.Aborted)
    {
      vtkDebugWithObjectMacro(self, << "Refinement aborted.");
      return Status::Aborted;
    }
    vtkErrorWithObjectMacro(self, << FilterName << " refinement failed: " << e.what());
    return Status::Failed;
  }
  const bridge::MaterialMesh& mesh = **this->Mesh;
  const rust::String unmet = mesh.tolerance_warning(query);
  if (!unmet.empty())
  {
    vtkWarningWithObjectMacro(self,
      << FilterName << ": " << std::string(unmet)
      << " (see MaximumInterfaceError, MaximumFieldError and the cell arrays).");
  }
  this->BuiltMesh = key;
  ++self->NumberOfRefinements;
  return Status::Done;
}

//------------------------------------------------------------------------------
void vtkMaterialInterfaceApproximation::vtkInternals::FillTetrahedra(
  vtkMaterialInterfaceApproximation* self, vtkDataSet* input, const bridge::MaterialMesh& mesh,
  vtkUnstructuredGrid* output, bool share)
{
  vtkSmartPointer<vtkPoints> points = PointsFrom(mesh.points());
  output->SetPoints(points);
  output->SetCells(VTK_TETRA, FixedSizeCells(4, mesh.tets(), points->GetNumberOfPoints()));
  // The query as given (its tolerances are written as field data).
  bridge::MaterialQuerySpec given;
  given.interface_tolerance = self->InterfaceTolerance;
  given.field_tolerance = self->FieldTolerance;
  given.ghost_values = self->UseGhostValues != 0;
  output->GetFieldData()->PassData(input->GetFieldData());
  AddOutputArrays(
    *mesh.tetrahedra_arrays(this->MaterialNames(), this->FieldNames(), given), output);
  if (share)
  {
    output->GetPointData()->SetGlobalIds(vtkDiamonds::GlobalPointIds(mesh.global_point_ids()));
  }
  vtkFieldData* fd = output->GetFieldData();
  fd->AddArray(Strings("MaterialNames", this->StdStrings(this->Materials)));
  fd->AddArray(
    Strings("InterfaceNames", this->StdStrings(mesh.interface_names(this->MaterialNames()))));
  fd->AddArray(Strings("FieldNames", this->StdStrings(this->Fields)));
}

//------------------------------------------------------------------------------
void vtkMaterialInterfaceApproximation::vtkInternals::FillInterfaces(
  const bridge::PolygonMesh& polygons, vtkPolyData* output, bool share)
{
  output->SetPoints(PointsFrom(polygons.points()));
  output->SetPolys(CellsFrom(polygons.offsets(), polygons.connectivity()));
  vtkFieldData* fd = output->GetFieldData();
  fd->AddArray(Strings("MaterialNames", this->StdStrings(this->Materials)));
  fd->AddArray(Strings(
    "InterfaceNames", this->StdStrings((**this->Mesh).interface_names(this->MaterialNames()))));
  AddOutputArrays(polygons.arrays(), output);
  if (share)
  {
    output->GetPointData()->SetGlobalIds(vtkDiamonds::GlobalPointIds(polygons.global_point_ids()));
  }
}

//------------------------------------------------------------------------------
bridge::PlaneSpec vtkMaterialInterfaceApproximation::vtkInternals::Plane(
  vtkMaterialInterfaceApproximation* self) const
{
  bridge::PlaneSpec plane;
  std::copy(self->SliceOrigin, self->SliceOrigin + 3, plane.origin.begin());
  std::copy(self->SliceNormal, self->SliceNormal + 3, plane.normal.begin());
  return plane;
}

void vtkMaterialInterfaceApproximation::vtkInternals::FillSlice(
  const bridge::PolygonMesh& slice, vtkPolyData* output, bool share)
{
  output->SetPoints(PointsFrom(slice.points()));
  output->SetPolys(CellsFrom(slice.offsets(), slice.connectivity()));
  output->GetFieldData()->AddArray(Strings("MaterialNames", this->StdStrings(this->Materials)));
  AddOutputArrays(slice.arrays(), output);
  if (share)
  {
    output->GetPointData()->SetGlobalIds(vtkDiamonds::GlobalPointIds(slice.global_point_ids()));
  }
}

//------------------------------------------------------------------------------
vtkMaterialInterfaceApproximation::vtkInternals::Status
vtkMaterialInterfaceApproximation::vtkInternals::Update(vtkMaterialInterfaceApproximation* self,
  vtkDataSet* input, vtkPolyData* interfaces, bridge::GridSpec& grid)
{
  const std::optional<bridge::GridSpec> g = GridOf(self, input);
  if (!g)
  {
    return Status::Failed;
  }
  grid = *g;
  const std::optional<bridge::ArraySelection> selection = this->SelectArrays(self, input);
  if (!selection)
  {
    return Status::Failed;
  }
  // The model (kept while its input is the same), then the mesh (kept while the query is).
  self->UpdateProgress(0.0);
  if (this->UpdateModel(self, input, interfaces, grid, *selection) == Status::Failed)
  {
    return Status::Failed;
  }
  self->UpdateProgress(0.3);
  if (self->CheckAbort())
  {
    return Status::Aborted;
  }
  const Status status = this->UpdateMesh(self, !selection->fields.empty());
  if (status != Status::Done)
  {
    return status;
  }
  self->UpdateProgress(0.85);
  return self->CheckAbort() ? Status::Aborted : Status::Done;
}

//------------------------------------------------------------------------------
int vtkMaterialInterfaceApproximation::vtkInternals::RequestDistributed(
  vtkMaterialInterfaceApproximation* self, vtkMultiProcessController* controller,
  vtkInformationVector** inputVector, vtkDataSet* input, vtkPolyData* interfaces,
  vtkUnstructuredGrid* tetOutput, vtkPolyData* interfaceOutput, vtkPolyData* sliceOutput)
{
  const auto started = std::chrono::steady_clock::now();
  const bool empty = input->GetNumberOfPoints() == 0;
  // Every rank takes part in every collective step below; a failure on one rank is agreed on
  // before the next one. Each step between two collective ones runs in Pieces::Run: whatever fails
  // on this rank (out of memory among it) is reported here and agreed on, so that all ranks leave
  // together with empty outputs.
  vtkDiamonds::Pieces pieces(controller, inputVector[0]->GetInformationObject(0), input);
  const auto run = [&](const char* failure, auto&& work) {
    return vtkDiamonds::Pieces::Run(self, FilterName, failure, work);
  };
  const auto clear = [&]() {
    tetOutput->Initialize();
    interfaceOutput->Initialize();
    sliceOutput->Initialize();
  };
  const auto agree = [&](bool mine, const char* what) {
    if (pieces.Agree(self, FilterName, mine, what))
    {
      return true;
    }
    clear();
    return false;
  };

  // ---- Parameters, and the arrays of this piece to gather (an empty piece reads none).
  bool ok = this->CheckParameters(self);
  std::vector<vtkDataArray*> pointArrays;
  std::vector<vtkDataArray*> cellArrays;
  if (ok && !empty)
  {
    ok = run("cannot read its input", [&] {
      const std::optional<bridge::ArraySelection> selection = this->SelectArrays(self, input);
      if (!selection)
      {
        return false;
      }
      std::vector<bridge::SelectedArray> read(
        selection->fractions.begin(), selection->fractions.end());
      for (const bridge::SelectedField& f : selection->fields)
      {
        if (!f.from_materials)
        {
          read.push_back(f.array);
        }
      }
      for (const bridge::SelectedMaterialField& m : selection->material_fields)
      {
        read.push_back(m.array);
      }
      for (const bridge::SelectedArray& a : read)
      {
        (a.cell ? cellArrays : pointArrays).push_back(ArrayOf(input, a));
      }
      return true;
    });
  }
  if (!agree(ok, "reading the input"))
  {
    return pieces.Failed();
  }

  // ---- The whole input on every rank with a piece, gathered again when any rank's input changed.
  std::vector<vtkDataArray*> gathered(pointArrays);
  gathered.push_back(nullptr);
  gathered.insert(gathered.end(), cellArrays.begin(), cellArrays.end());
  if (auto* rectilinear = vtkRectilinearGrid::SafeDownCast(input))
  {
    gathered.insert(gathered.end(), { rectilinear->GetXCoordinates(),
                                      rectilinear->GetYCoordinates(), rectilinear->GetZCoordinates() });
  }
  WholeKey key;
  for (vtkDataArray* a : gathered)
  {
    key.Arrays.push_back(a);
    key.MTimes.push_back(a ? a->GetMTime() : 0);
  }
  key.Extents.assign(pieces.Extents().begin(), pieces.Extents().end());
  std::copy(pieces.Whole().origin.begin(), pieces.Whole().origin.end(), key.Geometry.begin());
  std::copy(pieces.Whole().spacing.begin(), pieces.Whole().spacing.end(), key.Geometry.begin() + 3);
  if (pieces.Sum(this->WholeBuilt == key ? 0 : 1) > 0)
  {
    this->Release();
    this->Whole = nullptr;
    this->WholeBuilt = WholeKey();
    std::string error;
    ok = pieces.GatherWhole(input, pointArrays, cellArrays, this->Whole, error);
    if (!ok)
    {
      vtkErrorWithObjectMacro(
        self, << FilterName << " could not gather the input from the other ranks: " << error);
    }
    if (!agree(ok, "gathering the input"))
    {
      this->Whole = nullptr;
      return pieces.Failed();
    }
    this->WholeBuilt = key;
  }

  // ---- The serial approximation of the whole input, then this rank's share of each output.
  vtkDataSet* whole = this->Whole;
  Status status = Status::Done;
  if (whole)
  {
    const bool done = run("failed", [&] {
      bridge::GridSpec grid{};
      status = this->Update(self, whole, interfaces, grid);
      if (status != Status::Done)
      {
        return false;
      }
      const bridge::MaterialMesh& mesh = **this->Mesh;
      const std::size_t rank = static_cast<std::size_t>(pieces.Rank());
      this->FillTetrahedra(self, input, *mesh.piece(grid, pieces.Extents(), rank), tetOutput, true);
      this->FillInterfaces(
        *mesh.interface_polygons_piece(grid, pieces.Extents(), rank), interfaceOutput, true);
      this->FillSlice(
        *mesh.slice_piece(this->Plane(self), this->FieldNames(), grid, pieces.Extents(), rank),
        sliceOutput, true);
      return true;
    });
    if (!done && status == Status::Done)
    {
      status = Status::Failed;
    }
  }
  if (!agree(status == Status::Done, "the approximation"))
  {
    return pieces.Failed();
  }

  // ---- Totals over the ranks and the per-rank figures.
  const vtkIdType numTets = tetOutput->GetNumberOfCells();
  const vtkIdType totalTets = pieces.Sum(numTets);
  const vtkIdType totalPolygons = pieces.Sum(interfaceOutput->GetNumberOfCells());
  vtkFieldData* fd = tetOutput->GetFieldData();
  fd->AddArray(vtkDiamonds::OneValue<vtkIdTypeArray>("NumberOfTetrahedra", totalTets));
  pieces.AddFigures(fd, "TetrahedraPerRank", numTets, started);
  interfaceOutput->GetFieldData()->AddArray(
    vtkDiamonds::OneValue<vtkIdTypeArray>("NumberOfPolygons", totalPolygons));
  self->UpdateProgress(1.0);
  return 1;
}

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
try
{
  const vtkDiamonds::AbortLatch::Execution execution(this, this->Internals->Abort);
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
  using Status = vtkInternals::Status;

  if (vtkMultiProcessController* controller = vtkDiamonds::Pieces::DistributedController())
  {
    return internals.RequestDistributed(this, controller, inputVector, input, interfaceInput,
      tetOutput, interfaceOutput, sliceOutput);
  }

  // ---- Parameters, grid, arrays, model and mesh.
  if (!internals.CheckParameters(this))
  {
    return 0;
  }
  if (input->GetNumberOfPoints() == 0)
  {
    // Not an error: e.g. an empty piece of a parallel run.
    vtkDebugMacro(<< "The input is empty; the outputs are empty.");
    return 1;
  }
  bridge::GridSpec grid{};
  switch (internals.Update(this, input, interfaceInput, grid))
  {
    case Status::Done:
      break;
    case Status::Aborted:
      return 1;
    case Status::Failed:
      return 0;
  }

  // ---- The outputs: tetrahedra, approximated interfaces, slice.
  try
  {
    const bridge::MaterialMesh& mesh = **internals.Mesh;
    internals.FillTetrahedra(this, input, mesh, tetOutput, false);
    internals.FillInterfaces(*mesh.interface_polygons(), interfaceOutput, false);
    internals.FillSlice(
      *mesh.slice(internals.Plane(this), SliceOf(internals.Fields)), sliceOutput, false);
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
catch (const std::bad_alloc& e)
{
  vtkDiamonds::ReportOutOfMemory(this, "Material Interface Approximation", outputVector, e);
  return 0;
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
