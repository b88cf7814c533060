// A plain C++ MuJoCo program on terrasph's sand: loads the plugin library terrasph.rft, then any MJCF
// file that names it, and steps it, printing each body's vertical RFT load (the plugin's state) and
// the first body's height every `every` steps. No terrasph code is linked: the plugin is found at run time.
//
//   rft_plugin_step PLUGIN_LIBRARY MODEL.xml [STEPS=1000] [EVERY=100]
#include <mujoco/mujoco.h>

#include <cstdio>
#include <cstdlib>

int main(int argc, char** argv) {
  if (argc < 3) {
    std::fprintf(stderr, "usage: %s PLUGIN_LIBRARY MODEL.xml [STEPS] [EVERY]\n", argv[0]);
    return 2;
  }
  mj_loadPluginLibrary(argv[1]);
  char error[1000] = "";
  mjModel* m = mj_loadXML(argv[2], nullptr, error, sizeof(error));
  if (m == nullptr) {
    std::fprintf(stderr, "%s\n", error);
    return 1;
  }
  mjData* d = mj_makeData(m);
  const long steps = argc > 3 ? std::atol(argv[3]) : 1000, every = argc > 4 ? std::atol(argv[4]) : 100;
  for (long k = 1; k <= steps; ++k) {
    mj_step(m, d);
    if (k % every != 0) continue;
    double load = 0.0;  // the plugin's state: (F, τ) of each coupled body, six numbers per body
    for (int i = 2; i < m->npluginstate; i += 6) load += d->plugin_state[i];
    std::printf("%.4f %.6f %.6f\n", d->time, d->xpos[5], load);  // time, body 1's z, total vertical load
  }
  mj_deleteData(d);
  mj_deleteModel(m);
  return 0;
}
