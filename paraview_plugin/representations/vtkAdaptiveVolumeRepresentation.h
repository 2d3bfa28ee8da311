/**
 * @class   vtkAdaptiveVolumeRepresentation
 * @brief   "Adaptive Volume": image data volume-rendered as view-dependent tetrahedra in exact order
 *
 * vtkAdaptiveVolumeRepresentation shows a vtkImageData like ParaView's Volume representation (same
 * colour map, opacity function, scalar opacity unit distance and colouring array: it is a
 * vtkImageVolumeRepresentation whose properties it shares), but on every render it refines the
 * image's diamond hierarchy for the view's current camera and viewport under a per-frame budget
 * (vtkViewDependentTetrahedra: Gregorski et al. 2002, §4, §6.2, §8; the split and merge queues
 * carry the mesh from one render to the next) and draws the tetrahedra with
 * vtkProjectedTetrahedraMapper in the exact back-to-front order of the bisection tree
 * (Marchesin et al. 2004, §6): the refiner writes the mesh in that order for the render's camera
 * and vtkDiamondsVisibilitySort hands it to the mapper as it is. The hierarchy is built once per input
 * array; a render whose camera did not change refines nothing.
 *
 * Where it runs. The image is delivered to the rendering processes only (never to the client) and
 * distributed rendering is required, as for the Volume representation: in client-server mode the
 * server refines and renders, the client receives images. Under MPI each rendering rank refines and
 * renders its own piece of the image (its own hierarchy, the same camera and budget per rank) and
 * ParaView composites the pieces in depth order using their bounds (axis-aligned boxes, so the
 * compositing order is exact); the budget applies per rank (the refiner runs with
 * vtkViewDependentTetrahedra::MeshLocalPiece on). GetNumberOfTetrahedra and
 * GetNumberOfRefinements describe the process they are called on: in client-server mode the
 * client's copy, which only shows the server's images, reports 0.
 *
 * @sa
 * vtkViewDependentTetrahedra, vtkDiamondsVisibilitySort, vtkImageVolumeRepresentation,
 * vtkProjectedTetrahedraMapper
 */

#ifndef vtkAdaptiveVolumeRepresentation_h
#define vtkAdaptiveVolumeRepresentation_h

#include "vtkDiamondsRepresentationsModule.h" // For export macro
#include "vtkImageVolumeRepresentation.h"
#include "vtkNew.h" // For members

class vtkDiamondsVisibilitySort;
class vtkProjectedTetrahedraMapper;
class vtkViewDependentTetrahedra;

class VTKDIAMONDSREPRESENTATIONS_EXPORT vtkAdaptiveVolumeRepresentation
  : public vtkImageVolumeRepresentation
{
public:
  static vtkAdaptiveVolumeRepresentation* New();
  vtkTypeMacro(vtkAdaptiveVolumeRepresentation, vtkImageVolumeRepresentation);
  void PrintSelf(ostream& os, vtkIndent indent) override;

  int ProcessViewRequest(
    vtkInformationRequestKey* request_type, vtkInformation* inInfo, vtkInformation* outInfo) override;

  ///@{
  /**
   * Largest screen-space error in pixels (default 1) and the per-frame tetrahedron budget (default
   * 400,000; 0 = none), forwarded to the refinement.
   */
  void SetPixelTolerance(double value);
  double GetPixelTolerance();
  void SetMaximumNumberOfTetrahedra(vtkIdType value);
  vtkIdType GetMaximumNumberOfTetrahedra();
  ///@}

  /**
   * Tetrahedra of the last render's mesh, and how many times the mesh was refined (renders whose
   * camera, viewport, budget or data changed).
   */
  vtkIdType GetNumberOfTetrahedra();
  vtkGetMacro(NumberOfRefinements, vtkIdType);

  /**
   * How many times the visibility sort rebuilt a tree from the cells' bisection paths: none while
   * every render's mesh comes written back to front for its camera (see vtkDiamondsVisibilitySort).
   */
  vtkIdType GetNumberOfTreeBuilds();

protected:
  vtkAdaptiveVolumeRepresentation();
  ~vtkAdaptiveVolumeRepresentation() override;

  vtkNew<vtkViewDependentTetrahedra> Refiner;
  vtkNew<vtkDiamondsVisibilitySort> Sort;
  vtkNew<vtkProjectedTetrahedraMapper> TetrahedraMapper;
  vtkIdType NumberOfRefinements;

private:
  vtkAdaptiveVolumeRepresentation(const vtkAdaptiveVolumeRepresentation&) = delete;
  void operator=(const vtkAdaptiveVolumeRepresentation&) = delete;
};

#endif
