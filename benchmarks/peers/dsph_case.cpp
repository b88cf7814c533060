// The 2D dam break CaseDambreakVal2D written for DualSPHysics' solver without its GenCase.
//
// DualSPHysics' case generator GenCase is a closed-source binary; a checkout without it (such as a
// snapshot that leaves out large files) cannot make the case that the solver loads. This program
// writes that case itself: the same lattice, constants, particle blocks and execution parameters,
// through DualSPHysics' own classes (JXml, JCaseCtes, JCaseParts, JPartDataBi4), so the files are
// in the solver's formats by construction. It is compiled by benchmarks/peers/bench_dualsphysics.py
// against the sources of the user's checkout; no DualSPHysics code is part of terrasph.
//
//     dsph_case DEF_XML OUT_DIR CASE_NAME
//
// reads CASE_NAME_Def.xml (DEF_XML, with dp already changed), writes OUT_DIR/CASE_NAME.xml and
// OUT_DIR/CASE_NAME.bi4, and prints the particle counts.
//
// What it reproduces of GenCase, by the case definition's own rules (GenCase's manual, the
// comments of the _Def.xml): particles on the lattice x = i dp, z = k dp of the 2D plane y = 0;
// the boundary (mk 0) is the bottom, left and right faces of the tank box (0..4 m × 0..3 m), one
// layer; the fluid (mk 0) is the 1 m × 2 m box's nodes not taken by the boundary (the later draw
// keeps a node); h = coefh √(2 dp²) (2D), hswl = the column's height, speedsystem = √(g hswl),
// c0 = coefsound · speedsystem, B = c0² ρ0 / γ (Tait), every particle's mass ρ0 dp², the fluid's
// initial density hydrostatic in the column (rhopgradient 2: ρ = ρ0 (1 + ρ0 g (H − z)/B)^(1/γ)),
// the boundary's ρ0. Only the fluid box and the tank of this case are generated: the program
// checks that the definition's two boxes have these sizes.

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include "Functions.h"
#include "JCaseCtes.h"
#include "JCaseParts.h"
#include "JPartDataBi4.h"
#include "JXml.h"

namespace {

struct Lattice {
  std::vector<tdouble3> position;
  std::vector<float> density;
};

// Nodes i·dp of [lo, hi] (inclusive, within a millionth of dp): GenCase's lattice on one axis.
std::vector<double> nodes_within(double lo, double hi, double dp) {
  std::vector<double> out;
  const long first = long(std::ceil(lo / dp - 1e-6));
  const long last = long(std::floor(hi / dp + 1e-6));
  for (long i = first; i <= last; ++i) out.push_back(double(i) * dp);
  return out;
}

// The tank's bottom, left and right faces: one layer of nodes.
Lattice tank_walls(double dp, double width, double height) {
  Lattice walls;
  const std::vector<double> xs = nodes_within(0.0, width, dp);
  const std::vector<double> zs = nodes_within(0.0, height, dp);
  for (double x : xs) walls.position.push_back(TDouble3(x, 0.0, 0.0));
  for (double z : zs)
    if (z > 0.5 * dp) walls.position.push_back(TDouble3(0.0, 0.0, z));
  for (double z : zs)
    if (z > 0.5 * dp) walls.position.push_back(TDouble3(xs.back(), 0.0, z));
  return walls;
}

// The fluid column's nodes off the walls (x > 0, z > 0), hydrostatic Tait density (rhopgradient 2).
Lattice fluid_column(double dp, double width, double height, double rho0, double gravity, double b,
                     double gamma) {
  Lattice fluid;
  const std::vector<double> zs = nodes_within(0.0, height, dp);
  const double top = zs.back();
  for (double x : nodes_within(0.0, width, dp)) {
    if (x < 0.5 * dp) continue;
    for (double z : zs) {
      if (z < 0.5 * dp) continue;
      fluid.position.push_back(TDouble3(x, 0.0, z));
      // Tait EOS inverted for the hydrostatic pressure ρ0 g (H − z): ρ = ρ0 (1 + p/B)^(1/γ).
      fluid.density.push_back(float(rho0 * std::pow(1.0 + rho0 * gravity * (top - z) / b, 1.0 / gamma)));
    }
  }
  return fluid;
}

// The definition must be the dam break this program knows: a fluid box 1 × 2 m, then a tank 4 × 3 m.
void check_definition(JXml& xml, double column_width, double column_height, double tank_width,
                      double tank_height) {
  TiXmlNode* list = xml.GetNode("case.casedef.geometry.commands.mainlist", false);
  std::vector<tdouble3> sizes;
  for (TiXmlElement* e = list->FirstChildElement("drawbox"); e; e = e->NextSiblingElement("drawbox"))
    sizes.push_back(xml.ReadElementDouble3(e, "size"));
  const bool known = sizes.size() == 2 && sizes[0].x == column_width && sizes[0].z == column_height &&
                     sizes[1].x == tank_width && sizes[1].z == tank_height;
  if (!known) {
    std::fprintf(stderr, "dsph_case: the definition is not CaseDambreakVal2D's (a %g x %g m fluid box, then a "
                 "%g x %g m tank)\n", column_width, column_height, tank_width, tank_height);
    std::exit(2);
  }
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 4) {
    std::fprintf(stderr, "usage: dsph_case DEF_XML OUT_DIR CASE_NAME\n");
    return 2;
  }
  const std::string def_file = argv[1], out_dir = fun::GetDirWithSlash(argv[2]), case_name = argv[3];
  try {
    JXml xml;
    xml.LoadFile(def_file);
    const double tank_width = 4.0, tank_height = 3.0, column_width = 1.0, column_height = 2.0;
    check_definition(xml, column_width, column_height, tank_width, tank_height);
    const double dp = xml.ReadElementDouble(xml.GetNode("case.casedef.geometry", false)->ToElement(),
                                            "definition", "dp");
    JCaseCtes ctes;
    ctes.LoadXmlDef(&xml, "case.casedef.constantsdef");

    const double rho0 = ctes.GetRhop0();
    const double gravity = -ctes.GetGravity().z;
    const double hswl = nodes_within(0.0, column_height, dp).back();
    const double c0 = ctes.GetCoefSound() * std::sqrt(gravity * hswl);  // coefsound · speedsystem
    const double b = c0 * c0 * rho0 / ctes.GetGamma();                 // Tait: B = c0² ρ0 / γ
    const double mass = rho0 * dp * dp;                                  // 2D: ρ0 dp² per particle
    ctes.SetData2D(true, 0.0);
    ctes.SetDp(dp);
    ctes.SetH(ctes.ComputeFinalH(true, dp));
    ctes.SetB(b);
    ctes.SetMassBound(mass);
    ctes.SetMassFluid(mass);

    const Lattice walls = tank_walls(dp, tank_width, tank_height);
    const Lattice fluid = fluid_column(dp, column_width, column_height, rho0, gravity, b, ctes.GetGamma());
    const unsigned nbound = unsigned(walls.position.size()), nfluid = unsigned(fluid.position.size());
    const unsigned np = nbound + nfluid;

    std::vector<unsigned> ids(np);
    std::vector<tdouble3> positions(walls.position);
    positions.insert(positions.end(), fluid.position.begin(), fluid.position.end());
    std::vector<tfloat3> velocities(np, TFloat3(0));
    std::vector<float> densities(nbound, float(rho0));
    densities.insert(densities.end(), fluid.density.begin(), fluid.density.end());
    tdouble3 lo = positions[0], hi = positions[0];
    for (unsigned p = 0; p < np; ++p) {
      ids[p] = p;
      lo = MinValues(lo, positions[p]);
      hi = MaxValues(hi, positions[p]);
    }

    JCaseParts parts;
    // Mk numbering: fluid mk m is m + 1, bound mk m is m + fluidcount + 1 (<mkconfig>).
    const unsigned fluid_mks = xml.ReadElementUnsigned(xml.GetNode("case.casedef", false)->ToElement(),
                                                       "mkconfig", "fluidcount");
    parts.SetMkFirst(word(fluid_mks + 1), 1);
    parts.AddFixed(0, nbound);
    parts.AddFluid(0, nfluid);
    parts.SetPosDomain(lo, hi);

    ctes.SaveXmlRun(&xml, "case.execution.constants");
    parts.SaveXml(&xml, "case.execution.particles");
    fun::MkdirPath(out_dir);
    xml.SaveFile(out_dir + case_name + ".xml", "terrasph dsph_case", false);

    JPartDataBi4 data;
    data.ConfigBasic(0, 1, "", "terrasph dsph_case", case_name, true, 0.0, out_dir);
    data.ConfigParticles(np, nbound, 0, 0, nfluid, lo, hi, false, false);
    data.ConfigCtes(dp, ctes.GetH(), b, rho0, ctes.GetGamma(), mass, mass);
    data.AddPartInfo(0, 0.0, np, 0, 0, 0.0, lo, hi, 0, 0);
    data.AddPartData(np, ids.data(), positions.data(), velocities.data(), densities.data());
    data.SaveFileCase(case_name);
    std::printf("CaseNp=%u CaseNbound=%u CaseNfluid=%u dp=%g h=%.10g B=%.10g\n", np, nbound, nfluid, dp,
                ctes.GetH(), b);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "dsph_case: %s\n", e.what());
    return 1;
  }
  return 0;
}
