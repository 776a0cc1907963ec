// Geometry program of the vertex-geometry slicer (Zellmann & Lang's third variant): from the triangle P0, P2, P4 of
// slice_even.vert.glsl, the polygon with P1, P3 and P5 filled in where the plane crosses their dotted edges
// (V1-V5, V2-V6, V3-V4: the middle edge of rows 1, 3 and 5 of uPaths), as one triangle strip of three to six
// vertices.
//
// Only the vertices that exist are emitted, so the strip's order depends on which do (the paper's listing 3 and its
// figure 3). This order zigzags from P0 between the chains P0 -> P1 -> P2 -> P3 and P0 -> P5 -> P4 -> P3, which keeps
// every triangle counter-clockwise, as the fan's are, in all eight cases; the paper's order, which starts at P1 when
// it exists, turns the strip clockwise then. A plane outside the half-open box emits nothing. The dotted edges' end
// distances come from the vertex program: V1 and V4 are the middle corners of P0's path, V2 and V5 of P2's, V3 and
// V6 of P4's. The library slicer.glsl comes first.

layout(triangles) in;
layout(triangle_strip, max_vertices = 6) out;

in vec3 gWorld[];
in vec3 gBoxCoord[];
in vec2 gMiddleDistance[];
in int gCut[];
in vec3 gBoxMin[];
in vec3 gBoxMax[];
in ivec4 gPayload[];
in ivec3 gOwnLo[];
in ivec3 gOwnHi[];
in float gPlaneDistance[];

uniform mat4 uViewProj;  // world to clip
uniform int uPaths[24];  // the box corners along the path of P0..P5, four per path, front corner first

out vec3 vWorld;
out vec3 vBoxCoord;
flat out ivec4 vPayload;
flat out ivec3 vOwnLo;
flat out ivec3 vOwnHi;
flat out float vPlaneDistance;

// Emits one strip vertex; outputs are undefined after each EmitVertex, so all of them are written every time.
void emit(vec3 world, vec3 boxCoord) {
  vWorld = world;
  vBoxCoord = boxCoord;
  vPayload = gPayload[0];
  vOwnLo = gOwnLo[0];
  vOwnHi = gOwnHi[0];
  vPlaneDistance = gPlaneDistance[0];
  gl_Position = uViewProj * vec4(world, 1.0);
  EmitVertex();
}

// The odd vertex of row `row` of uPaths (1, 3 or 5), where its dotted edge, whose ends lie at distances di and dj,
// holds the plane; false when it does not.
bool oddVertex(int row, float di, float dj, out vec3 world, out vec3 boxCoord) {
  precise float lambda;
  precise vec3 w, b;
  world = vec3(0.0);
  boxCoord = vec3(0.0);
  if (!crossEdge(di, dj, gPlaneDistance[0], lambda)) return false;
  edgePoint(gBoxMin[0], gBoxMax[0], uPaths[row * 4 + 1], uPaths[row * 4 + 2], lambda, w, b);
  world = w;
  boxCoord = b;
  return true;
}

void main() {
  if (gCut[0] == 0) return;
  vec3 world1, coord1, world3, coord3, world5, coord5;
  const bool has1 = oddVertex(1, gMiddleDistance[0].x, gMiddleDistance[1].y, world1, coord1);  // V1 -> V5
  const bool has3 = oddVertex(3, gMiddleDistance[1].x, gMiddleDistance[2].y, world3, coord3);  // V2 -> V6
  const bool has5 = oddVertex(5, gMiddleDistance[2].x, gMiddleDistance[0].y, world5, coord5);  // V3 -> V4

  emit(gWorld[0], gBoxCoord[0]);
  if (has1) {
    emit(world1, coord1);
    if (has5) {
      emit(world5, coord5);
      emit(gWorld[1], gBoxCoord[1]);
      emit(gWorld[2], gBoxCoord[2]);
    } else {
      emit(gWorld[2], gBoxCoord[2]);
      emit(gWorld[1], gBoxCoord[1]);
    }
    if (has3) emit(world3, coord3);
  } else {
    emit(gWorld[1], gBoxCoord[1]);
    if (has5) {
      emit(world5, coord5);
      if (has3) emit(world3, coord3);
      emit(gWorld[2], gBoxCoord[2]);
    } else {
      emit(gWorld[2], gBoxCoord[2]);
      if (has3) emit(world3, coord3);
    }
  }
  EndPrimitive();
}
