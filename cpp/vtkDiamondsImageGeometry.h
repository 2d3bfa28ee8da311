// Internal to the Diamonds VTK module (not installed, not wrapped): the geometry of an input image or
// image piece: its extent, origin and spacing, axis alignment, the whole image's bounds across
// pieces, a region of interest checked against them, and no ghost levels.
#ifndef vtkDiamondsImageGeometry_h
#define vtkDiamondsImageGeometry_h

#include <algorithm>
#include <limits>

class vtkAlgorithm;
class vtkImageData;
class vtkInformationVector;

namespace vtkDiamonds
{
struct FilterText;

// The geometry of an image (or image piece) as VTK reports it.
struct ImageGeometry
{
  int Extent[6];
  int Dims[3];
  double Origin[3];
  double Spacing[3];

  explicit ImageGeometry(vtkImageData* input);
};

// Whether the image's direction matrix is the identity to within 1e-9 per entry (a matrix
// computed by a rotation and its inverse differs from it by rounding).
bool IsAxisAligned(vtkImageData* input);

// Reports an error on `filter` and returns false unless the image is axis-aligned (IsAxisAligned).
bool CheckAxisAligned(vtkAlgorithm* filter, const FilterText& text, vtkImageData* input);

// World bounds of the whole image (WHOLE_EXTENT when the pipeline gives it, else the input's own
// extent): regions of interest and relative tolerances refer to the whole data set, not a piece.
void WholeBounds(vtkInformationVector** inputVector, vtkImageData* input, double bounds[6]);

// Length of the whole image's diagonal (WholeBounds): what relative tolerances are relative to.
double WholeDiagonal(vtkInformationVector** inputVector, vtkImageData* input);

// Checks `roi` (finite, min <= max, touching the whole image); reports an error on `filter` and
// returns false otherwise. `touchesPiece` tells whether it touches this process's piece.
bool CheckRegionOfInterest(vtkAlgorithm* filter, const double roi[6],
  vtkInformationVector** inputVector, vtkImageData* input, bool& touchesPiece);

// Sets the region of interest of a query (`spec`: bridge::QuerySpec or bridge::IsoSpec) from the
// filter's UseRegionOfInterest and RegionOfInterest: when used, `roi` is checked (an error is reported
// on `filter` and false returned otherwise), and a region that misses this piece makes no diamond
// here of interest (tolerance infinite: the coarsest mesh or surface).
template <typename Spec>
bool SetRegionOfInterest(vtkAlgorithm* filter, int use, const double roi[6],
  vtkInformationVector** inputVector, vtkImageData* input, Spec& spec)
{
  spec.use_region_of_interest = false;
  std::copy(roi, roi + 6, spec.region_of_interest.begin());
  bool touchesPiece = false;
  if (!use)
  {
    return true;
  }
  if (!CheckRegionOfInterest(filter, roi, inputVector, input, touchesPiece))
  {
    return false;
  }
  if (touchesPiece)
  {
    spec.use_region_of_interest = true;
  }
  else
  {
    spec.tolerance = std::numeric_limits<double>::max();
  }
  return true;
}

// Asks the filter's input for no ghost levels: each piece is processed over its own extent (a ghost
// layer would be processed twice, once by each neighbouring piece; pieces of an image share their
// boundary plane of points, so nothing is lost).
void RequestNoGhostLevels(vtkInformationVector** inputVector);

} // namespace vtkDiamonds

#endif
