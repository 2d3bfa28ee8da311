/**
 * @class   vtkProgressiveTetrahedralMesh
 * @brief   progressive tetrahedral mesh of an unstructured grid (base mesh + vertex splits)
 *
 * vtkProgressiveTetrahedralMesh simplifies a tetrahedral vtkUnstructuredGrid by half-edge
 * collapses (Labsik et al., "Progressive Isosurface Extraction from Tetrahedral Meshes", §3) into
 * a coarse base mesh and a sequence of vertex splits, and outputs the level that meets
 * TargetReduction and MaximumFieldError. Every kept vertex is an original one, so every point array
 * passes through unchanged. The collapses are ordered by the weighted cost of §3.3 (GeometryWeight:
 * error quadrics of the boundary faces; FieldWeight: field error; ShapeWeight: condition-number
 * shape measure) and must pass the validity tests of §3.2 (no flipped or degenerate tetrahedra,
 * link condition, boundary rule; with PreserveBoundary corners and feature edges stay and removed
 * boundary vertices stay within BoundaryTolerance of the boundary). The field error reported is
 * exact: the largest |f(v) - L(v)| over the removed original vertices v.
 *
 * The sequence is computed once per input (array, values, weights, boundary settings), as far as
 * the coarsest TargetReduction asked so far: a finer level, or MaximumFieldError, only replays
 * vertex splits or collapses from the current level; a coarser one continues the same sequence
 * from where it stopped (the levels made keep their meshes; the sequence is the one a single run to
 * that level makes). GetNumberOfSimplifications() counts the computations from the input.
 *
 * Input: tetrahedra (other cells are tetrahedralised first, with a warning); coincident points are
 * merged and the tetrahedra they flatten dropped. Output port 0: VTK_TETRA cells at the chosen
 * level, all point data, cell data "FieldError" (the largest error of the removed vertices inside
 * each tetrahedron), field data "Level", "NumberOfLevels", "NumberOfTetrahedra", "MaximumFieldError"
 * and "RMSFieldError". Output port 1 (with ComputeIsosurface): the progressive isosurface of the
 * contour values on that level (§4): marching tetrahedra kept up to date under each replayed split
 * or collapse for its tetrahedra only, new isovalues found through an interval tree over the
 * level's tetrahedra (§4.2); one point per crossed edge (watertight inside the mesh), point data
 * named after Scalars holding the isovalue.
 */

#ifndef vtkProgressiveTetrahedralMesh_h
#define vtkProgressiveTetrahedralMesh_h

#include "vtkDiamondsModule.h" // For export macro
#include "vtkUnstructuredGridAlgorithm.h"

class vtkContourValues;

class VTKDIAMONDS_EXPORT vtkProgressiveTetrahedralMesh : public vtkUnstructuredGridAlgorithm
{
public:
  static vtkProgressiveTetrahedralMesh* New();
  vtkTypeMacro(vtkProgressiveTetrahedralMesh, vtkUnstructuredGridAlgorithm);
  void PrintSelf(ostream& os, vtkIndent indent) override;

  ///@{
  /**
   * Fraction of the tetrahedra to remove, 0-1 (like Decimate's). Default 0.9.
   */
  vtkSetMacro(TargetReduction, double);
  vtkGetMacro(TargetReduction, double);
  ///@}

  ///@{
  /**
   * Largest field error at a removed vertex, data units; 0 (default) = no limit. The output is the
   * coarsest level whose error, and every finer level's, is within it (it may remove fewer
   * tetrahedra than TargetReduction asks).
   */
  vtkSetMacro(MaximumFieldError, double);
  vtkGetMacro(MaximumFieldError, double);
  ///@}

  ///@{
  /**
   * Weights of the geometric, field and shape errors in the collapse cost (§3.3, Eq. 2); the
   * geometric error is over the squared bounding-box diagonal, the field error over the squared
   * value range. Defaults 1, 1, 0: the shape measure is unbounded and any weight that makes it
   * count outweighs the field error; flipped and flat tetrahedra are refused without it.
   */
  vtkSetMacro(GeometryWeight, double);
  vtkGetMacro(GeometryWeight, double);
  vtkSetMacro(FieldWeight, double);
  vtkGetMacro(FieldWeight, double);
  vtkSetMacro(ShapeWeight, double);
  vtkGetMacro(ShapeWeight, double);
  ///@}

  ///@{
  /**
   * Keep the boundary: corners and feature edges stay, removed boundary vertices stay within
   * BoundaryTolerance (a fraction of the bounding-box diagonal, default 0.001). Default on.
   */
  vtkSetMacro(PreserveBoundary, vtkTypeBool);
  vtkGetMacro(PreserveBoundary, vtkTypeBool);
  vtkBooleanMacro(PreserveBoundary, vtkTypeBool);
  vtkSetMacro(BoundaryTolerance, double);
  vtkGetMacro(BoundaryTolerance, double);
  ///@}

  ///@{
  /**
   * Extract the isosurfaces of the contour values on output port 1. Default off.
   */
  vtkSetMacro(ComputeIsosurface, vtkTypeBool);
  vtkGetMacro(ComputeIsosurface, vtkTypeBool);
  vtkBooleanMacro(ComputeIsosurface, vtkTypeBool);
  ///@}

  ///@{
  /**
   * The contour values (isovalues) of output port 1, as in vtkContourFilter.
   */
  void SetValue(int i, double value);
  double GetValue(int i);
  void SetNumberOfContours(int number);
  vtkIdType GetNumberOfContours();
  ///@}

  vtkMTimeType GetMTime() override;

  /**
   * Number of times the filter has computed the collapse sequence (not when only TargetReduction
   * or MaximumFieldError changed).
   */
  vtkGetMacro(NumberOfSimplifications, vtkIdType);

protected:
  vtkProgressiveTetrahedralMesh();
  ~vtkProgressiveTetrahedralMesh() override;

  int FillInputPortInformation(int port, vtkInformation* info) override;
  int FillOutputPortInformation(int port, vtkInformation* info) override;
  int RequestData(vtkInformation*, vtkInformationVector**, vtkInformationVector*) override;

  double TargetReduction;
  double MaximumFieldError;
  double GeometryWeight;
  double FieldWeight;
  double ShapeWeight;
  vtkTypeBool PreserveBoundary;
  double BoundaryTolerance;
  vtkIdType NumberOfSimplifications;
  vtkTypeBool ComputeIsosurface;
  vtkContourValues* ContourValues;

private:
  vtkProgressiveTetrahedralMesh(const vtkProgressiveTetrahedralMesh&) = delete;
  void operator=(const vtkProgressiveTetrahedralMesh&) = delete;

  class vtkInternals;
  vtkInternals* Internals;
};

#endif
