/**
 * @class   vtkViewDependentTetrahedra
 * @brief   the tetrahedral mesh of an image refined for one camera, optionally in exact visibility order
 *
 * vtkViewDependentTetrahedra converts a 3-D vtkImageData into a conforming mesh of VTK_TETRA cells
 * refined where a camera sees detail: every diamond of the image's diamond hierarchy (see
 * vtkAdaptiveTetrahedra) is split while its screen-space error exceeds PixelTolerance
 * (Gregorski et al. 2002, "Recursive Tetrahedral Meshes for Scientific Visualization", §6.2):
 * its approximation error, read as a height with the value range spanning the image diagonal,
 * projected at the nearest distance from the eye of a box holding the diamond's whole subtree, in
 * pixels of a viewport of ViewportSize under ViewAngle. The error bound of a diamond is the
 * largest in its subtree (Marchesin et al. 2004, "View-Dependent Isosurface Extraction ...", §4.2),
 * so a split diamond's parents are always split and the mesh is the same whatever mesh the
 * refinement started from. Diamonds outside the view frustum get error 0 and stay coarse.
 *
 * Frame coherence (Gregorski §4, §8). The filter keeps, between executions, the hierarchy (rebuilt
 * only when the array, its values or the image geometry change) and the previous execution's mesh
 * with its split and merge queues: a new camera re-evaluates the queued diamonds, then splits
 * those above the tolerance and merges those at or below it, largest split error and smallest
 * merge error first. With MaximumNumberOfTetrahedra the working tolerance rises until the mesh
 * fits (field data PixelToleranceReached). The result equals a fresh refinement for the same view
 * (tested in the core); field data FrameSplits, FrameMerges and FrameSeconds tell what the update
 * did.
 *
 * Order. SortCells 1 (2) writes the cells back to front (front to back) as seen from
 * CameraPosition, exactly: every bisection plane is a plane of a binary space partition of the
 * mesh (Marchesin §6), so visiting the far child of every bisection first orders any two
 * tetrahedra sharing a face correctly, under perspective and with the eye inside the volume. The
 * core writes the mesh in that order directly (its walk of the bisection forest takes the far
 * child first; no tree is built and nothing is reordered) and the output is marked
 * (vtkDiamondsVisibilitySort::ORDERED_FROM), so that vtkDiamondsVisibilitySort, asked for the
 * same eye, hands the cells out as they are: the Adaptive Volume representation's path.
 * Whatever SortCells, each cell carries its bisection path (cell data "BisectionPath", unsigned
 * 64-bit: root tetrahedron, child at each bisection, depth) and the field data "BisectionGrid"
 * (the hierarchy's grid: 3 dimensions, origin, spacing), from which vtkDiamondsVisibilitySort
 * orders the cells for any later camera, wherever the cells went.
 *
 * Output: points at the input sample positions with all input point data; VTK_TETRA cells with
 * cell data "BisectionDepth", "Level" (BisectionDepth / 3, Gregorski's level), "ApproximationError"
 * (the error bound of the tetrahedron's diamond, data units) and "BisectionPath"; field data
 * "BisectionGrid", "PixelToleranceReached", "NumberOfTetrahedra", "FrameSplits", "FrameMerges",
 * "FrameSeconds".
 *
 * Errors (vtkErrorMacro, empty output): those of vtkAdaptiveTetrahedra's input; a camera whose
 * position equals its focal point, whose view up is parallel to the view direction, a view angle
 * outside (0, 180), a viewport below 1 pixel, a negative or non-finite PixelTolerance, a negative
 * MaximumNumberOfTetrahedra, SortCells outside 0-2; more than one MPI rank (the view-dependent mesh
 * is computed on one process: use the Adaptive Volume representation, which refines on each
 * rendering process).
 *
 * @sa
 * vtkAdaptiveTetrahedra, vtkDiamondsVisibilitySort, vtkProjectedTetrahedraMapper,
 * vtkCellCenterDepthSort
 */

#ifndef vtkViewDependentTetrahedra_h
#define vtkViewDependentTetrahedra_h

#include "vtkDiamondsModule.h" // For export macro
#include "vtkUnstructuredGridAlgorithm.h"

class VTKDIAMONDS_EXPORT vtkViewDependentTetrahedra : public vtkUnstructuredGridAlgorithm
{
public:
  static vtkViewDependentTetrahedra* New();
  vtkTypeMacro(vtkViewDependentTetrahedra, vtkUnstructuredGridAlgorithm);
  void PrintSelf(ostream& os, vtkIndent indent) override;

  ///@{
  /**
   * The camera, as vtkCamera describes it: position (eye), focal point, view up, vertical view
   * angle in degrees. Defaults those of vtkCamera: (0, 0, 1), (0, 0, 0), (0, 1, 0), 30.
   */
  vtkSetVector3Macro(CameraPosition, double);
  vtkGetVector3Macro(CameraPosition, double);
  vtkSetVector3Macro(CameraFocalPoint, double);
  vtkGetVector3Macro(CameraFocalPoint, double);
  vtkSetVector3Macro(CameraViewUp, double);
  vtkGetVector3Macro(CameraViewUp, double);
  vtkSetMacro(ViewAngle, double);
  vtkGetMacro(ViewAngle, double);
  ///@}

  ///@{
  /**
   * Viewport width and height in pixels (the screen-space error is measured against the height).
   * Default 1024 x 768.
   */
  vtkSetVector2Macro(ViewportSize, int);
  vtkGetVector2Macro(ViewportSize, int);
  ///@}

  ///@{
  /**
   * Largest screen-space error in pixels, >= 0. Default 1.
   */
  vtkSetMacro(PixelTolerance, double);
  vtkGetMacro(PixelTolerance, double);
  ///@}

  ///@{
  /**
   * Upper bound on the number of tetrahedra; 0 means no limit. Default 1,000,000.
   */
  vtkSetMacro(MaximumNumberOfTetrahedra, vtkIdType);
  vtkGetMacro(MaximumNumberOfTetrahedra, vtkIdType);
  ///@}

  ///@{
  /**
   * Cell order of the output: 0 as refined (default; ascending bisection paths, the order in which
   * vtkDiamondsVisibilitySort rebuilds its tree in one pass), 1 back to front, 2 front to back
   * from CameraPosition (exact).
   */
  vtkSetMacro(SortCells, int);
  vtkGetMacro(SortCells, int);
  ///@}

  /**
   * Number of hierarchies built (one per execution whose array or geometry changed).
   */
  vtkGetMacro(NumberOfHierarchyBuilds, vtkIdType);

  ///@{
  /**
   * Under MPI (more than one rank): off (default), the filter refuses to run; on, every rank
   * refines the piece of the image it holds for the camera, on its own (its own hierarchy and
   * budget, no exchange, so the meshes of neighbouring pieces need not conform across their shared
   * face). The Adaptive Volume representation turns it on: its ranks render their pieces apart and
   * ParaView composites them in depth order. Not a proxy property.
   */
  vtkSetMacro(MeshLocalPiece, bool);
  vtkGetMacro(MeshLocalPiece, bool);
  vtkBooleanMacro(MeshLocalPiece, bool);
  ///@}

protected:
  vtkViewDependentTetrahedra();
  ~vtkViewDependentTetrahedra() override;

  int FillInputPortInformation(int port, vtkInformation* info) override;
  int RequestData(vtkInformation*, vtkInformationVector**, vtkInformationVector*) override;

  double CameraPosition[3];
  double CameraFocalPoint[3];
  double CameraViewUp[3];
  double ViewAngle;
  int ViewportSize[2];
  double PixelTolerance;
  vtkIdType MaximumNumberOfTetrahedra;
  int SortCells;
  vtkIdType NumberOfHierarchyBuilds;
  bool MeshLocalPiece;

private:
  vtkViewDependentTetrahedra(const vtkViewDependentTetrahedra&) = delete;
  void operator=(const vtkViewDependentTetrahedra&) = delete;

  class vtkInternals;
  vtkInternals* Internals;
};

#endif
