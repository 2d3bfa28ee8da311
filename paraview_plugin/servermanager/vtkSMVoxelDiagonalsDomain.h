/**
 * @class   vtkSMVoxelDiagonalsDomain
 * @brief   a length domain whose default is a number of voxel diagonals of the input
 *
 * Like vtkSMBoundsDomain in its approximate_cell_length mode (the range is 0 to the diagonal of the
 * input's bounds), but the default is `voxel_diagonals` times the approximate cell length: the
 * diagonal of the input's bounds divided by the cube root of its number of cells (about one voxel
 * diagonal for an image), or `voxel_diagonals` while the input's bounds are unknown.
 * (vtkSMBoundsDomain documents its scale_factor for this mode but ignores it.)
 *
 * XML, with the property `Input` required as for vtkSMBoundsDomain:
 * @code{xml}
 * <VoxelDiagonalsDomain name="voxel_diagonals" voxel_diagonals="2.5">
 *   <RequiredProperties><Property name="Input" function="Input" /></RequiredProperties>
 * </VoxelDiagonalsDomain>
 * @endcode
 */

#ifndef vtkSMVoxelDiagonalsDomain_h
#define vtkSMVoxelDiagonalsDomain_h

#include "vtkDiamondsServerManagerModule.h" // For export macro
#include "vtkSMBoundsDomain.h"

class VTKDIAMONDSSERVERMANAGER_EXPORT vtkSMVoxelDiagonalsDomain : public vtkSMBoundsDomain
{
public:
  static vtkSMVoxelDiagonalsDomain* New();
  vtkTypeMacro(vtkSMVoxelDiagonalsDomain, vtkSMBoundsDomain);
  void PrintSelf(ostream& os, vtkIndent indent) override;

  /// Sets the property to `voxel_diagonals` approximate cell lengths of the input.
  int SetDefaultValues(vtkSMProperty* property, bool use_unchecked_values) override;

  /// The number of voxel diagonals of the default (XML attribute `voxel_diagonals`, default 1).
  vtkGetMacro(VoxelDiagonals, double);

protected:
  vtkSMVoxelDiagonalsDomain();
  ~vtkSMVoxelDiagonalsDomain() override;

  int ReadXMLAttributes(vtkSMProperty* property, vtkPVXMLElement* element) override;

private:
  vtkSMVoxelDiagonalsDomain(const vtkSMVoxelDiagonalsDomain&) = delete;
  void operator=(const vtkSMVoxelDiagonalsDomain&) = delete;

  double VoxelDiagonals = 1.0;
};

#endif
