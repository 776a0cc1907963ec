// The frame ray caster's fragment kernel (render/gl/volume/RayCastPass.h): one fragment per pixel
// (raycast.vert.glsl) marches its pixel's ray through the batch (marchPixel, volume_march.glsl) and is blended once
// into the target, front to back; the silhouette map keeps the pixels that terminated in earlier batches from
// being started at all.

// The depth test (the silhouette map) before the program runs: a program with atomics would otherwise be run and
// then tested. Marching fragments neither discard nor write depth, so the result is the same.
layout(early_fragment_tests) in;

out vec4 fragColor;

void main() { fragColor = marchPixel(gl_FragCoord.xy); }
