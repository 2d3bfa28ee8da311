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
 * (one pass over paths in the order meshes are written, otherwise sorting them, O(n log n)); each
 * traversal for a new camera is linear in the number of cells.
 *
 * Orders given by the producer. vtkViewDependentTetrahedra with SortCells 1 or 2 has the core write
 * its tetrahedra in the exact order from its CameraPosition (the bisection tree walked far child
 * first while writing, no tree built) and marks its output with ORDERED_FROM: the eye, the
 * direction, the modification time of its "BisectionPath" array and the number of cells. When the
 * input carries that mark, still true (same paths array, unmodified, same number of cells), and
 * this sort's eye is that eye exactly, the order is the cells' own (or its reverse for the other
 * direction): no tree is built and nothing is sorted. This is the path of the Adaptive Volume
 * representation, whose refiner writes its mesh back to front from the camera of each render. The
 * mark is information of that one data object (copies of the data do not carry it); anything else
 * — another eye, a copy, reordered or filtered cells — is ordered from the paths as above.
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

class vtkInformationDoubleVectorKey;

class VTKDIAMONDS_EXPORT vtkDiamondsVisibilitySort : public vtkVisibilitySort
{
public:
  static vtkDiamondsVisibilitySort* New();
  vtkTypeMacro(vtkDiamondsVisibilitySort, vtkVisibilitySort);
  void PrintSelf(ostream& os, vtkIndent indent) override;

  void InitTraversal() override;
  vtkIdTypeArray* GetNextCells() override;

  /**
   * Number of times the tree was rebuilt from the paths (once per new input), and of traversals
   * that took the order the input was written in (ORDERED_FROM).
   */
  vtkGetMacro(NumberOfTreeBuilds, vtkIdType);
  vtkGetMacro(NumberOfGivenOrders, vtkIdType);

  /**
   * The mark of a mesh whose cells are in exact visibility order from an eye: 3 eye coordinates,
   * the direction (vtkVisibilitySort::BACK_TO_FRONT or FRONT_TO_BACK), the modification time of
   * its "BisectionPath" cell array and its number of cells. Set with MarkOrdered.
   */
  static vtkInformationDoubleVectorKey* ORDERED_FROM();

  ///@{
  /**
   * Marks `mesh` (in the information of the data object) as written in exact visibility order from
   * `eye` in `direction`, after its "BisectionPath" array was added (without that array, the mark
   * is removed); Unmark removes the mark.
   */
  static void MarkOrdered(vtkDataSet* mesh, const double eye[3], int direction);
  static void Unmark(vtkDataSet* mesh);
  ///@}

  /**
   * Seconds of the last tree build and of the last traversal (InitTraversal).
   */
  vtkGetMacro(LastBuildSeconds, double);
  vtkGetMacro(LastOrderSeconds, double);

protected:
  vtkDiamondsVisibilitySort();
  ~vtkDiamondsVisibilitySort() override;

  vtkIdType NumberOfTreeBuilds;
  vtkIdType NumberOfGivenOrders;
  double LastBuildSeconds;
  double LastOrderSeconds;

private:
  vtkDiamondsVisibilitySort(const vtkDiamondsVisibilitySort&) = delete;
  void operator=(const vtkDiamondsVisibilitySort&) = delete;

  class vtkInternals;
  vtkInternals* Internals;
};

#endif
