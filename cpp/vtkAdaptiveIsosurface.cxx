#include "vtkAdaptiveIsosurface.h"

#include "vtkCellArray.h"
#include "vtkContourValues.h"
#include "vtkDataArray.h"
#include "vtkDataSetAttributes.h"
#include "vtkDoubleArray.h"
#include "vtkFieldData.h"
#include "vtkFloatArray.h"
#include "vtkIdTypeArray.h"
#include "vtkImageData.h"
#include "vtkInformation.h"
#include "vtkInformationVector.h"
#include "vtkObjectFactory.h"
#include "vtkPointData.h"
#include "vtkPoints.h"
#include "vtkPolyData.h"
#include "vtkStreamingDemandDrivenPipeline.h"
#include "vtkTypeInt32Array.h"
#include "vtkTypeInt64Array.h"
#include "vtkUnstructuredGrid.h"

// The module's internal helpers and the cxx bridge. Kept out of the public header: the VTK
// wrappers parse that one.
#include "vtkDiamondsArraySelection.h"
#include "vtkDiamondsHierarchyCache.h"
#include "vtkDiamondsImageGeometry.h"
#include "vtkDiamondsOutput.h"

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <optional>
#include <string>
#include <vector>

vtkStandardNewMacro(vtkAdaptiveIsosurface);

namespace
{
namespace bridge = diamonds::bridge;
using vtkDiamonds::FixedSizeCells;
using vtkDiamonds::NamedArray;
using vtkDiamonds::OneValue;

const vtkDiamonds::FilterText Text = { "Adaptive Isosurface", "contour", "contours",
  "Contour By" };
} // namespace

class vtkAdaptiveIsosurface::vtkInternals
{
public:
  // The extraction reads the samples again: keep them with the hierarchy.
  vtkDiamonds::HierarchyCache Cache{ vtkDiamonds::HierarchyCache::Use::Isosurfaces };

  // The isovalues, once they, Tolerance and MaximumNumberOfTriangles are checked.
  std::optional<std::vector<double>> CheckParameters(vtkAdaptiveIsosurface* self);
  // The surface as points, triangles and, when asked for, normals and scalars (of `array`'s type).
  void FillSurface(vtkAdaptiveIsosurface* self, const bridge::Surface& surface,
    vtkDataArray* array, vtkPolyData* output);
};

//------------------------------------------------------------------------------
vtkAdaptiveIsosurface::vtkAdaptiveIsosurface()
  : ContourValues(vtkContourValues::New())
  , Tolerance(0.0)
  , RelativeTolerance(0.0)
  , MaximumNumberOfTriangles(0)
  , UseRegionOfInterest(0)
  , RegionOfInterest{ 0.0, 1.0, 0.0, 1.0, 0.0, 1.0 }
  , ComputeNormals(1)
  , ComputeScalars(0)
  , GenerateCarrierTetrahedra(0)
  , NumberOfHierarchyBuilds(0)
  , NumberOfReusedMeshes(0)
  , Internals(new vtkInternals)
{
  this->SetNumberOfOutputPorts(2);
  // Default: the active point scalars.
  this->SetInputArrayToProcess(
    0, 0, 0, vtkDataObject::FIELD_ASSOCIATION_POINTS, vtkDataSetAttributes::SCALARS);
}

//------------------------------------------------------------------------------
vtkAdaptiveIsosurface::~vtkAdaptiveIsosurface()
{
  this->ContourValues->Delete();
  delete this->Internals;
}

//------------------------------------------------------------------------------
vtkMTimeType vtkAdaptiveIsosurface::GetMTime()
{
  return std::max(this->Superclass::GetMTime(), this->ContourValues->GetMTime());
}

//------------------------------------------------------------------------------
void vtkAdaptiveIsosurface::SetValue(int i, double value)
{
  this->ContourValues->SetValue(i, value);
}

double vtkAdaptiveIsosurface::GetValue(int i)
{
  return this->ContourValues->GetValue(i);
}

double* vtkAdaptiveIsosurface::GetValues()
{
  return this->ContourValues->GetValues();
}

void vtkAdaptiveIsosurface::SetNumberOfContours(int number)
{
  this->ContourValues->SetNumberOfContours(number);
}

vtkIdType vtkAdaptiveIsosurface::GetNumberOfContours()
{
  return this->ContourValues->GetNumberOfContours();
}

void vtkAdaptiveIsosurface::GenerateValues(int numContours, double rangeStart, double rangeEnd)
{
  this->ContourValues->GenerateValues(numContours, rangeStart, rangeEnd);
}

//------------------------------------------------------------------------------
int vtkAdaptiveIsosurface::FillInputPortInformation(int, vtkInformation* info)
{
  info->Set(vtkAlgorithm::INPUT_REQUIRED_DATA_TYPE(), "vtkImageData");
  return 1;
}

//------------------------------------------------------------------------------
int vtkAdaptiveIsosurface::FillOutputPortInformation(int port, vtkInformation* info)
{
  // Port 0: the isosurface; port 1: the tetrahedra carrying it.
  info->Set(vtkDataObject::DATA_TYPE_NAME(), port == 0 ? "vtkPolyData" : "vtkUnstructuredGrid");
  return 1;
}

//------------------------------------------------------------------------------
int vtkAdaptiveIsosurface::RequestUpdateExtent(
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
vtkIdType vtkAdaptiveIsosurface::GetHierarchyMemorySize()
{
  return this->Internals->Cache.GetMemorySize();
}

//------------------------------------------------------------------------------
void vtkAdaptiveIsosurface::ReleaseHierarchy()
{
  this->Internals->Cache.Release();
}

//------------------------------------------------------------------------------
std::optional<std::vector<double>> vtkAdaptiveIsosurface::vtkInternals::CheckParameters(
  vtkAdaptiveIsosurface* self)
{
  vtkContourValues* contours = self->ContourValues;
  const int numValues = static_cast<int>(contours->GetNumberOfContours());
  if (numValues < 1)
  {
    vtkErrorWithObjectMacro(
      self, << "No isovalue: add at least one value to Isosurfaces (SetValue).");
    return std::nullopt;
  }
  std::vector<double> isovalues(contours->GetValues(), contours->GetValues() + numValues);
  for (int i = 0; i < numValues; ++i)
  {
    if (!std::isfinite(isovalues[i]))
    {
      vtkErrorWithObjectMacro(self,
        << "Isosurfaces value " << i << " is " << isovalues[i]
        << "; every isovalue must be a finite number.");
      return std::nullopt;
    }
  }
  if (!std::isfinite(self->Tolerance) || self->Tolerance < 0.0)
  {
    vtkErrorWithObjectMacro(self,
      << "Tolerance must be a finite number >= 0 (got " << self->Tolerance
      << "); it is in world units, 0 gives the full-resolution surface.");
    return std::nullopt;
  }
  if (self->MaximumNumberOfTriangles < 0)
  {
    vtkErrorWithObjectMacro(self,
      << "MaximumNumberOfTriangles must be >= 0 (got " << self->MaximumNumberOfTriangles
      << "); 0 means no limit.");
    return std::nullopt;
  }
  return isovalues;
}

//------------------------------------------------------------------------------
void vtkAdaptiveIsosurface::vtkInternals::FillSurface(vtkAdaptiveIsosurface* self,
  const bridge::Surface& surface, vtkDataArray* array, vtkPolyData* output)
{
  const rust::Slice<const std::uint32_t> triangles = surface.triangles();
  const rust::Slice<const double> values = surface.values();
  const vtkIdType numPoints = static_cast<vtkIdType>(values.size());
  vtkSmartPointer<vtkPoints> points = vtkDiamonds::PointsFrom(surface.points());
  output->SetPoints(points);
  output->SetPolys(FixedSizeCells(3, triangles, numPoints));
  if (self->ComputeNormals)
  {
    const rust::Slice<const float> normals = surface.normals();
    vtkNew<vtkFloatArray> normalArray;
    normalArray->SetName("Normals");
    normalArray->SetNumberOfComponents(3);
    normalArray->SetNumberOfTuples(numPoints);
    std::copy(normals.begin(), normals.end(), normalArray->GetPointer(0));
    output->GetPointData()->SetNormals(normalArray);
  }
  if (self->ComputeScalars)
  {
    // Of the input array's type, as vtkFlyingEdges3D does.
    vtkSmartPointer<vtkDataArray> scalars =
      vtkSmartPointer<vtkDataArray>::Take(vtkDataArray::CreateDataArray(array->GetDataType()));
    scalars->SetName(array->GetName());
    scalars->SetNumberOfComponents(1);
    scalars->SetNumberOfTuples(numPoints);
    for (vtkIdType i = 0; i < numPoints; ++i)
    {
      scalars->SetComponent(i, 0, values[i]);
    }
    output->GetPointData()->SetScalars(scalars);
  }
}

//------------------------------------------------------------------------------
int vtkAdaptiveIsosurface::RequestData(
  vtkInformation*, vtkInformationVector** inputVector, vtkInformationVector* outputVector)
{
  vtkImageData* input = vtkImageData::GetData(inputVector[0]);
  vtkPolyData* output = vtkPolyData::GetData(outputVector, 0);
  vtkUnstructuredGrid* carrier = vtkUnstructuredGrid::GetData(outputVector, 1);
  if (!input || !output || !carrier)
  {
    vtkErrorMacro(<< "Adaptive Isosurface needs a vtkImageData input.");
    return 0;
  }
  // Every error below leaves empty outputs.
  output->Initialize();
  carrier->Initialize();
  this->RelativeTolerance = 0.0;

  // ---- Parameters, geometry, the array to contour.
  const std::optional<std::vector<double>> isovalues = this->Internals->CheckParameters(this);
  if (!isovalues)
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
  if (!cache.Prepare(this, Text, input, array, 0.0, 0.7, this->NumberOfHierarchyBuilds, result))
  {
    return result;
  }

  // ---- Extraction. The cache's isosurface state belongs to its hierarchy (recreated with every
  // build): the adaptive mesh of the previous execution is reused when only ComputeNormals,
  // ComputeScalars or GenerateCarrierTetrahedra changed; otherwise it is refined from the root.
  bridge::IsoSpec spec;
  spec.tolerance = this->Tolerance;
  spec.max_triangles = static_cast<std::size_t>(this->MaximumNumberOfTriangles);
  spec.compute_normals = this->ComputeNormals != 0;
  spec.carrier_tetrahedra = this->GenerateCarrierTetrahedra != 0;
  if (!vtkDiamonds::SetRegionOfInterest(
        this, this->UseRegionOfInterest, this->RegionOfInterest, inputVector, input, spec))
  {
    return 0;
  }
  std::optional<rust::Box<bridge::Surface>> surface;
  try
  {
    surface.emplace(cache.GetHierarchy().isosurface(cache.GetIsoState(), cache.GetSampleType(),
      cache.GetSamples(), rust::Slice<const double>(isovalues->data(), isovalues->size()), spec));
  }
  catch (const rust::Error& e)
  {
    vtkErrorMacro(<< "Adaptive Isosurface extraction failed for array \"" << array->GetName()
                  << "\": " << e.what());
    return 0;
  }
  try
  {
    for (const rust::String& warning : (*surface)->warnings())
    {
      vtkWarningMacro(<< "Adaptive Isosurface, array \"" << array->GetName()
                      << "\": " << std::string(warning));
    }
  }
  catch (const rust::Error& e)
  {
    vtkErrorMacro(<< "Adaptive Isosurface: " << e.what());
    return 0;
  }
  if (cache.GetIsoState().reused())
  {
    ++this->NumberOfReusedMeshes;
  }
  this->UpdateProgress(0.9);
  if (this->CheckAbort())
  {
    return 1;
  }

  // ---- Output port 0: the surface.
  this->Internals->FillSurface(this, **surface, array, output);
  this->RelativeTolerance = relativeTolerance;
  vtkFieldData* fieldData = output->GetFieldData();
  fieldData->PassData(input->GetFieldData());
  fieldData->AddArray(OneValue<vtkDoubleArray>("ErrorBound", (*surface)->error_bound()));
  fieldData->AddArray(OneValue<vtkIdTypeArray>("NumberOfTriangles", output->GetNumberOfCells()));
  fieldData->AddArray(OneValue<vtkDoubleArray>("Tolerance", this->Tolerance));
  fieldData->AddArray(OneValue<vtkDoubleArray>("RelativeTolerance", relativeTolerance));

  // ---- Output port 1: the tetrahedra carrying the surface.
  if (this->GenerateCarrierTetrahedra)
  {
    std::optional<rust::Box<bridge::Mesh>> mesh;
    try
    {
      mesh.emplace((*surface)->take_carrier());
    }
    catch (const rust::Error& e)
    {
      vtkErrorMacro(<< e.what());
      output->Initialize();
      return 0;
    }
    vtkDiamonds::MeshToUnstructuredGrid(**mesh, input, "IsosurfaceError", carrier);
    carrier->GetFieldData()->AddArray(
      OneValue<vtkIdTypeArray>("NumberOfTetrahedra", carrier->GetNumberOfCells()));
    carrier->GetFieldData()->AddArray(OneValue<vtkDoubleArray>("MaximumError", (*mesh)->max_error()));
  }

  this->UpdateProgress(1.0);
  return 1;
}

//------------------------------------------------------------------------------
void vtkAdaptiveIsosurface::PrintSelf(ostream& os, vtkIndent indent)
{
  this->Superclass::PrintSelf(os, indent);
  this->ContourValues->PrintSelf(os, indent.GetNextIndent());
  os << indent << "Tolerance: " << this->Tolerance << "\n";
  os << indent << "RelativeTolerance: " << this->RelativeTolerance << "\n";
  os << indent << "MaximumNumberOfTriangles: " << this->MaximumNumberOfTriangles << "\n";
  os << indent << "UseRegionOfInterest: " << (this->UseRegionOfInterest ? "On" : "Off") << "\n";
  os << indent << "RegionOfInterest: (" << this->RegionOfInterest[0] << ", "
     << this->RegionOfInterest[1] << ", " << this->RegionOfInterest[2] << ", "
     << this->RegionOfInterest[3] << ", " << this->RegionOfInterest[4] << ", "
     << this->RegionOfInterest[5] << ")\n";
  os << indent << "ComputeNormals: " << (this->ComputeNormals ? "On" : "Off") << "\n";
  os << indent << "ComputeScalars: " << (this->ComputeScalars ? "On" : "Off") << "\n";
  os << indent << "GenerateCarrierTetrahedra: " << (this->GenerateCarrierTetrahedra ? "On" : "Off")
     << "\n";
  os << indent << "NumberOfHierarchyBuilds: " << this->NumberOfHierarchyBuilds << "\n";
  os << indent << "NumberOfReusedMeshes: " << this->NumberOfReusedMeshes << "\n";
  os << indent << "HierarchyMemorySize: " << this->GetHierarchyMemorySize() << "\n";
}
