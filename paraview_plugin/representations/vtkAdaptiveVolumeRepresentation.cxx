#include "vtkAdaptiveVolumeRepresentation.h"

#include "vtkAlgorithmOutput.h"
#include "vtkCallbackCommand.h"
#include "vtkCamera.h"
#include "vtkCommand.h"
#include "vtkDataObject.h"
#include "vtkDiamondsVisibilitySort.h"
#include "vtkInformation.h"
#include "vtkObjectFactory.h"
#include "vtkPVLODVolume.h"
#include "vtkPVRenderView.h"
#include "vtkProjectedTetrahedraMapper.h"
#include "vtkUnstructuredGrid.h"
#include "vtkViewDependentTetrahedra.h"

#include <algorithm>

vtkStandardNewMacro(vtkAdaptiveVolumeRepresentation);

//------------------------------------------------------------------------------
vtkAdaptiveVolumeRepresentation::vtkAdaptiveVolumeRepresentation()
  : NumberOfRefinements(0)
{
  this->Refiner->SetMaximumNumberOfTetrahedra(400000);
  this->Refiner->SetPixelTolerance(1.0);
  // The refiner writes each render's mesh back to front from that render's camera, and the sort
  // hands that order to the mapper as it is (no tree, nothing sorted; see vtkDiamondsVisibilitySort).
  this->Refiner->SetSortCells(1);
  this->Refiner->MeshLocalPieceOn(); // under MPI every rank refines and renders its own piece
  vtkNew<vtkCallbackCommand> counter; // counts the refiner's executions
  counter->SetClientData(this);
  counter->SetCallback([](vtkObject*, unsigned long, void* self, void*) {
    ++static_cast<vtkAdaptiveVolumeRepresentation*>(self)->NumberOfRefinements;
  });
  this->Refiner->AddObserver(vtkCommand::EndEvent, counter);
  this->TetrahedraMapper->SetVisibilitySort(this->Sort);
  this->TetrahedraMapper->SetInputConnection(this->Refiner->GetOutputPort());
}

//------------------------------------------------------------------------------
vtkAdaptiveVolumeRepresentation::~vtkAdaptiveVolumeRepresentation() = default;

//------------------------------------------------------------------------------
int vtkAdaptiveVolumeRepresentation::ProcessViewRequest(
  vtkInformationRequestKey* request_type, vtkInformation* inInfo, vtkInformation* outInfo)
{
  if (!this->Superclass::ProcessViewRequest(request_type, inInfo, outInfo))
  {
    return 0;
  }
  if (request_type != vtkPVView::REQUEST_RENDER())
  {
    return 1;
  }
  // The superclass connected the delivered image to its volume mapper and chose the colouring
  // array; the actor draws the tetrahedra instead, refined for this render's camera.
  vtkPVRenderView* view = vtkPVRenderView::SafeDownCast(inInfo->Get(vtkPVView::VIEW()));
  vtkAlgorithmOutput* image = vtkPVRenderView::GetPieceProducer(inInfo, this, 0);
  if (!view || !image)
  {
    return 1;
  }
  this->Refiner->SetInputConnection(image);
  const char* name = nullptr;
  vtkInformation* info = this->GetInputArrayInformation(0);
  if (info && info->Has(vtkDataObject::FIELD_NAME()))
  {
    name = info->Get(vtkDataObject::FIELD_NAME());
  }
  if (name && name[0])
  {
    this->Refiner->SetInputArrayToProcess(0, 0, 0, vtkDataObject::FIELD_ASSOCIATION_POINTS, name);
    this->TetrahedraMapper->SetScalarMode(VTK_SCALAR_MODE_USE_POINT_FIELD_DATA);
    this->TetrahedraMapper->SelectScalarArray(name);
  }
  vtkCamera* camera = view->GetActiveCamera();
  this->Refiner->SetCameraPosition(camera->GetPosition());
  this->Refiner->SetCameraFocalPoint(camera->GetFocalPoint());
  this->Refiner->SetCameraViewUp(camera->GetViewUp());
  this->Refiner->SetViewAngle(camera->GetViewAngle());
  const int* size = view->GetSize();
  this->Refiner->SetViewportSize(std::max(size[0], 1), std::max(size[1], 1));
  this->Actor->SetMapper(this->TetrahedraMapper);
  return 1;
}

//------------------------------------------------------------------------------
void vtkAdaptiveVolumeRepresentation::SetPixelTolerance(double value)
{
  if (value != this->Refiner->GetPixelTolerance())
  {
    this->Refiner->SetPixelTolerance(value);
    this->Modified();
  }
}

double vtkAdaptiveVolumeRepresentation::GetPixelTolerance()
{
  return this->Refiner->GetPixelTolerance();
}

void vtkAdaptiveVolumeRepresentation::SetMaximumNumberOfTetrahedra(vtkIdType value)
{
  if (value != this->Refiner->GetMaximumNumberOfTetrahedra())
  {
    this->Refiner->SetMaximumNumberOfTetrahedra(value);
    this->Modified();
  }
}

vtkIdType vtkAdaptiveVolumeRepresentation::GetMaximumNumberOfTetrahedra()
{
  return this->Refiner->GetMaximumNumberOfTetrahedra();
}

vtkIdType vtkAdaptiveVolumeRepresentation::GetNumberOfTetrahedra()
{
  vtkUnstructuredGrid* mesh = this->Refiner->GetOutput();
  return mesh ? mesh->GetNumberOfCells() : 0;
}

vtkIdType vtkAdaptiveVolumeRepresentation::GetNumberOfTreeBuilds()
{
  return this->Sort->GetNumberOfTreeBuilds();
}

//------------------------------------------------------------------------------
void vtkAdaptiveVolumeRepresentation::PrintSelf(ostream& os, vtkIndent indent)
{
  this->Superclass::PrintSelf(os, indent);
  os << indent << "PixelTolerance: " << this->Refiner->GetPixelTolerance() << "\n";
  os << indent << "MaximumNumberOfTetrahedra: " << this->Refiner->GetMaximumNumberOfTetrahedra()
     << "\n";
  os << indent << "NumberOfRefinements: " << this->NumberOfRefinements << "\n";
  os << indent << "NumberOfTreeBuilds: " << this->Sort->GetNumberOfTreeBuilds() << "\n";
}
