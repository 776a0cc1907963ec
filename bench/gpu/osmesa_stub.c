/* A stand-in for libOSMesa.so.8 in the GPU kit (bench/gpu/pack.sh builds it). Mesa's real library pulls in LLVM
 * (about 100 MB); on a GPU machine voxbrick renders through EGL, so the kit carries this instead: every entry point
 * voxbrick's OSMesa backend (render/gl/OsMesaContext.cpp) calls, each failing cleanly, so that backend reports
 * "OSMesaCreateContextAttribs returned no context" and EGL is used. */
#include <stddef.h>

typedef struct osmesa_context *OSMesaContext;
typedef void (*OSMESAproc)(void);

OSMesaContext OSMesaCreateContextAttribs(const int *attribList, OSMesaContext sharelist) {
  (void)attribList;
  (void)sharelist;
  return NULL;
}

void OSMesaDestroyContext(OSMesaContext ctx) { (void)ctx; }

unsigned char OSMesaMakeCurrent(OSMesaContext ctx, void *buffer, unsigned int type, int width, int height) {
  (void)ctx;
  (void)buffer;
  (void)type;
  (void)width;
  (void)height;
  return 0;
}

OSMesaContext OSMesaGetCurrentContext(void) { return NULL; }

OSMESAproc OSMesaGetProcAddress(const char *funcName) {
  (void)funcName;
  return NULL;
}

/* Names this library as the stand-in: voxbrick's osMesaStandIn (render/gl/OsMesaContext.cpp) looks it up, so that
 * the GL tests skip their OSMesa cases with this reason (there is no OSMesa backend here) instead of failing. */
const char *voxbrick_osmesa_stand_in(void) {
  return "the GPU kit's stand-in for libOSMesa (bench/gpu/osmesa_stub.c): no OSMesa backend";
}
