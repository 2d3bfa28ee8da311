/**
 * @class   vtkDiamondsVisibilitySort
 * @brief   exact visibility order of adaptive tetrahedra from their bisection tree
 *
 * vtkDiamondsVisibilitySort gives vtkProjectedTetrahedraMapper (or any user of a
 * vtkVisibilitySort) the exact back-to-front or front-to-back order of the tetrahedra of a mesh
 * made by longest-edge bisection (vtkViewDependentTetrahedra): every bisection plane is a plane of
 * a binary space partition of the mesh (Marchesin, Dischler, Mongenet 2004, "3D ROAM for
 * Scalable Volume Visualization", §6), so visiting, at every bisection, first the child on the far
 * side of its plane from the eye orders any two tetrahedra that share a face correctly: under
 * perspective, with the eye inside the volume, on a plane. vtkCellCenterDepthSort, the mapper's
 * default, sorts cell centres along the view direction, which is approximate.
 *
 * What it reads. The input's cell data "BisectionPath" (unsigned 64-bit: the root tetrahedron,
 * the child taken at each bisection and the depth, see diamonds::view::BspTree::paths) and field
 * data "BisectionGrid" (the dimensions, origin and spacing of the image the mesh was refined on),
 * both written by vtkViewDependentTetrahedra. The order is rebuilt from them, so it does not
 * depend on cell ids: cells reordered, redistributed between processes, or a subset of them (a
 * threshold) are ordered exactly all the same. The tree is rebuilt when the input changes
 * (sorting the paths, O(n log n)); each traversal for a new camera is linear in the number of
 * cells.
 *
 * The eye is the camera position taken into the data's coordinates by the inverse of the model
 * transform. A parallel projection is handled as an eye 10^6 bounding-box diagonals away along
 * the view direction (exact unless a bisection plane is within 10^-6 radians of parallel to the
 * view direction, where either order is visually equivalent).
 *
 * Errors (vtkErrorMacro; GetNextCells then returns nullptr at once, so nothing is drawn): no
 * "BisectionPath" or "BisectionGrid" array, paths that do not belong to that grid or overlap.
 *
 * @sa
 * vtkVisibilitySort, vtkCellCenterDepthSort, vtkProjectedTetrahedraMapper,
 * vtkViewDependentTetrahedra
 */

#ifndef vtkDiamondsVisibilitySort_h
#define vtkDiamondsVisibilitySort_h

#include "vtkDiamondsModule.h" // For export macro
#include "vtkVisibilitySort.h"

class VTKDIAMONDS_EXPORT vtkDiamondsVisibilitySort : public vtkVisibilitySort
{
public:
  static vtkDiamondsVisibilitySort* New();
  vtkTypeMacro(vtkDiamondsVisibilitySort, vtkVisibilitySort);
  void PrintSelf(ostream& os, vtkIndent indent) override;

  void InitTraversal() override;
  vtkIdTypeArray* GetNextCells() override;

  /**
   * Number of times the tree was rebuilt from the paths (once per new input).
   */
  vtkGetMacro(NumberOfTreeBuilds, vtkIdType);

  /**
   * Seconds of the last tree build and of the last traversal (InitTraversal).
   */
  vtkGetMacro(LastBuildSeconds, double);
  vtkGetMacro(LastOrderSeconds, double);

protected:
  vtkDiamondsVisibilitySort();
  ~vtkDiamondsVisibilitySort() override;

  vtkIdType NumberOfTreeBuilds;
  double LastBuildSeconds;
  double LastOrderSeconds;

private:
  vtkDiamondsVisibilitySort(const vtkDiamondsVisibilitySort&) = delete;
  void operator=(const vtkDiamondsVisibilitySort&) = delete;

  class vtkInternals;
  vtkInternals* Internals;
};

#endif
