#include "vtkDiamondsVisibilitySort.h"

#include "vtkCamera.h"
#include "vtkCellData.h"
#include "vtkDataArray.h"
#include "vtkDataSet.h"
#include "vtkFieldData.h"
#include "vtkIdTypeArray.h"
#include "vtkInformation.h"
#include "vtkInformationDoubleVectorKey.h"
#include "vtkMatrix4x4.h"
#include "vtkObjectFactory.h"
#include "vtkTypeUInt64Array.h"

// The cxx bridge (kept out of the public header).
#include "vtkDiamondsBridge.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <numeric>
#include <optional>
#include <vector>

vtkStandardNewMacro(vtkDiamondsVisibilitySort);
vtkInformationKeyRestrictedMacro(vtkDiamondsVisibilitySort, ORDERED_FROM, DoubleVector, 6);

namespace
{
namespace bridge = diamonds::bridge;
using Clock = std::chrono::steady_clock;
double Since(Clock::time_point start)
{
  return std::chrono::duration<double>(Clock::now() - start).count();
}
} // namespace

class vtkDiamondsVisibilitySort::vtkInternals
{
public:
  // The tree of the input it was built for (identity and modification time, never dereferenced).
  std::optional<rust::Box<bridge::PathOrder>> Tree;
  const void* BuiltFor = nullptr;
  vtkMTimeType BuiltTime = 0;
  // The order of the last traversal and the chunk GetNextCells hands out (a view into it).
  std::vector<vtkIdType> Order;
  std::size_t Next = 0;
  vtkNew<vtkIdTypeArray> Chunk;
};

//------------------------------------------------------------------------------
vtkDiamondsVisibilitySort::vtkDiamondsVisibilitySort()
  : NumberOfTreeBuilds(0)
  , NumberOfGivenOrders(0)
  , LastBuildSeconds(0.0)
  , LastOrderSeconds(0.0)
  , Internals(new vtkInternals)
{
}

//------------------------------------------------------------------------------
vtkDiamondsVisibilitySort::~vtkDiamondsVisibilitySort()
{
  delete this->Internals;
}

//------------------------------------------------------------------------------
void vtkDiamondsVisibilitySort::InitTraversal()
{
  vtkInternals& in = *this->Internals;
  in.Order.clear();
  in.Next = 0;
  vtkDataSet* input = this->Input;
  if (!input || !this->Camera)
  {
    vtkErrorMacro(<< "vtkDiamondsVisibilitySort needs an input and a camera.");
    return;
  }
  if (input->GetNumberOfCells() == 0)
  {
    return;
  }
  // The eye in the data's coordinates.
  double position[4] = { 0.0, 0.0, 0.0, 1.0 };
  this->Camera->GetPosition(position);
  if (this->Camera->GetParallelProjection())
  {
    double focal[3];
    this->Camera->GetFocalPoint(focal);
    const double far = 1e6 * std::max(input->GetLength(), 1e-300);
    const double distance = std::max(this->Camera->GetDistance(), 1e-300);
    for (int a = 0; a < 3; ++a)
    {
      position[a] = focal[a] + (position[a] - focal[a]) * (far / distance);
    }
  }
  if (this->ModelTransform)
  {
    vtkNew<vtkMatrix4x4> inverse;
    vtkMatrix4x4::Invert(this->ModelTransform, inverse);
    inverse->MultiplyPoint(position, position);
    for (int a = 0; a < 3; ++a)
    {
      position[a] /= position[3];
    }
  }
  // The order the cells were written in, when they were written for this eye (MarkOrdered).
  vtkTypeUInt64Array* paths =
    vtkTypeUInt64Array::SafeDownCast(input->GetCellData()->GetAbstractArray("BisectionPath"));
  const double* mark = input->GetInformation()->Get(ORDERED_FROM());
  if (mark && paths && static_cast<double>(paths->GetMTime()) == mark[4] &&
    static_cast<double>(input->GetNumberOfCells()) == mark[5] && position[0] == mark[0] &&
    position[1] == mark[1] && position[2] == mark[2])
  {
    const auto start = Clock::now();
    in.Order.resize(static_cast<std::size_t>(input->GetNumberOfCells()));
    if (static_cast<int>(mark[3]) == this->Direction)
    {
      std::iota(in.Order.begin(), in.Order.end(), vtkIdType(0));
    }
    else
    {
      std::iota(in.Order.rbegin(), in.Order.rend(), vtkIdType(0));
    }
    this->LastOrderSeconds = Since(start);
    ++this->NumberOfGivenOrders;
    this->LastSortTime.Modified();
    return;
  }

  if (!in.Tree || in.BuiltFor != input || in.BuiltTime != input->GetMTime())
  {
    in.Tree.reset();
    vtkDataArray* grid = input->GetFieldData()->GetArray("BisectionGrid");
    if (!paths || paths->GetNumberOfComponents() != 1 || !grid ||
      grid->GetNumberOfValues() != 9)
    {
      vtkErrorMacro(<< "vtkDiamondsVisibilitySort orders the output of View Dependent "
                       "Tetrahedra: it needs the cell data \"BisectionPath\" (unsigned 64-bit) "
                       "and the field data \"BisectionGrid\" (9 values), which this input lacks.");
      return;
    }
    bridge::GridSpec spec;
    for (int a = 0; a < 3; ++a)
    {
      const double d = grid->GetComponent(a, 0);
      spec.dims[a] = d >= 0.0 && d < 1e12 ? static_cast<std::size_t>(d) : 0;
      spec.origin[a] = grid->GetComponent(3 + a, 0);
      spec.spacing[a] = grid->GetComponent(6 + a, 0);
    }
    const auto buildStart = Clock::now();
    try
    {
      in.Tree.emplace(bridge::new_path_order(spec,
        rust::Slice<const std::uint64_t>(
          reinterpret_cast<const std::uint64_t*>(paths->GetPointer(0)),
          static_cast<std::size_t>(paths->GetNumberOfValues()))));
    }
    catch (const rust::Error& e)
    {
      vtkErrorMacro(<< "vtkDiamondsVisibilitySort cannot order this input: " << e.what());
      return;
    }
    this->LastBuildSeconds = Since(buildStart);
    in.BuiltFor = input;
    in.BuiltTime = input->GetMTime();
    ++this->NumberOfTreeBuilds;
  }

  const auto start = Clock::now();
  in.Order.resize((*in.Tree)->number_of_cells());
  try
  {
    static_assert(sizeof(vtkIdType) == sizeof(std::int64_t), "64-bit ids");
    (*in.Tree)->order_cells(rust::Slice<const double>(position, 3),
      this->Direction == vtkVisibilitySort::FRONT_TO_BACK,
      rust::Slice<std::int64_t>(reinterpret_cast<std::int64_t*>(in.Order.data()), in.Order.size()));
  }
  catch (const rust::Error& e)
  {
    in.Order.clear();
    vtkErrorMacro(<< "vtkDiamondsVisibilitySort could not order the cells: " << e.what());
    return;
  }
  this->LastOrderSeconds = Since(start);
  this->LastSortTime.Modified();
}

//------------------------------------------------------------------------------
vtkIdTypeArray* vtkDiamondsVisibilitySort::GetNextCells()
{
  vtkInternals& in = *this->Internals;
  if (in.Next >= in.Order.size())
  {
    return nullptr;
  }
  const std::size_t count =
    std::min(in.Order.size() - in.Next, static_cast<std::size_t>(this->MaxCellsReturned));
  // A view into the order (save = 1: the chunk does not own the memory).
  in.Chunk->SetArray(in.Order.data() + in.Next, static_cast<vtkIdType>(count), 1);
  in.Next += count;
  return in.Chunk;
}

//------------------------------------------------------------------------------
void vtkDiamondsVisibilitySort::PrintSelf(ostream& os, vtkIndent indent)
{
  this->Superclass::PrintSelf(os, indent);
  os << indent << "NumberOfTreeBuilds: " << this->NumberOfTreeBuilds << "\n";
  os << indent << "NumberOfGivenOrders: " << this->NumberOfGivenOrders << "\n";
  os << indent << "LastBuildSeconds: " << this->LastBuildSeconds << "\n";
  os << indent << "LastOrderSeconds: " << this->LastOrderSeconds << "\n";
}

//------------------------------------------------------------------------------
void vtkDiamondsVisibilitySort::MarkOrdered(vtkDataSet* mesh, const double eye[3], int direction)
{
  vtkDataArray* paths = mesh->GetCellData()->GetArray("BisectionPath");
  if (!paths)
  {
    vtkDiamondsVisibilitySort::Unmark(mesh);
    return;
  }
  const double mark[6] = { eye[0], eye[1], eye[2], static_cast<double>(direction),
    static_cast<double>(paths->GetMTime()), static_cast<double>(mesh->GetNumberOfCells()) };
  mesh->GetInformation()->Set(ORDERED_FROM(), mark, 6);
}

//------------------------------------------------------------------------------
void vtkDiamondsVisibilitySort::Unmark(vtkDataSet* mesh)
{
  mesh->GetInformation()->Remove(ORDERED_FROM());
}
