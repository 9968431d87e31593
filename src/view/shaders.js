// cubeforge view: the GLSL ES 3.00 programs. The fragment program ray-casts the unit sphere per
// sample (per fragment, or against preview's tessellated mesh per vertex) and runs the source
// texts' vertex and fragment programs (The Cg Tutorial, chapter 7; Brennan's finite radius)
// and split-sum pbr, each line written from the same formula as src/preview's.
'use strict';

window.cubeforgeShaders = {
  VS: `#version 300 es
  in vec2 pos;
  void main() { gl_Position = vec4(pos, 0.0, 1.0); }`,

  // The fragment program without its first line: the renderer puts the version and the
  // variant's constants before it (MODEL 0 reflect, 1 refract, 2 dispersion, 3 pbr;
  // PER_VERTEX, CROSS, SEAMS and EXACT 0 or 1), so each variant compiles only what it runs.
  FS: `
  precision highp float;
  precision highp samplerCube;
  uniform samplerCube env;
  uniform samplerCube chain;      // pbr's GGX chain
  uniform samplerCube irradiance; // pbr's diffuse: the map's irradiance over pi
  uniform sampler2D decal;
  uniform sampler2D control;
  uniform sampler2D dfg;
  uniform bool hasDecal, hasControl, lodOn;
  uniform vec3 decalColor, etaRatio, baseColor;
  uniform float reflectivity, transmittance, fresnelBias, fresnelScale, fresnelPower;
  uniform float metallic, roughness, f0, pbrLod, maxLodBias;
  uniform float lodBias, bgLevel, exposure, halfSize, size;
  uniform int tonemap, samples;
  uniform vec2 offsets[16];
  uniform vec3 eye, fwd, right, up;
  uniform float tanHalf;
  uniform int parallax;           // 0 none, 1 approx, 2 exact (Brennan)
  uniform float envRadius;
  uniform vec3 envCenter;
  uniform vec2 origin;            // this cell's corner in the canvas (a sweep's row)
  uniform float crossCell;
  uniform int bands;              // the per-vertex mesh's latitude bands
  out vec4 color;

  const float PI = 3.14159265358979;

  vec3 ray(vec2 s) {
    float x = (2.0 * s.x / size - 1.0) * tanHalf;
    float y = (1.0 - 2.0 * s.y / size) * tanHalf;
    return fwd + right * x + up * y;
  }
  // The nearest point where the ray meets the unit sphere (preview's sphere::hit).
  bool hit(vec3 o, vec3 d, out vec3 p) {
    vec3 dn = normalize(d);
    float b = dot(o, dn);
    if (b >= 0.0) return false;
    vec3 w = o - dn * b;
    float h2 = dot(w, w);
    if (h2 > 1.0) return false;
    p = w - dn * sqrt(1.0 - h2);
    return true;
  }
  vec2 sphereUv(vec3 p) {
    float u = 0.5 + atan(p.x, p.z) / (2.0 * PI);
    float v = acos(clamp(p.y / length(p), -1.0, 1.0)) / PI;
    return vec2(min(u, 1.0 - 0.5 * 1.1920929e-7), v);
  }
  vec3 refr(vec3 i, vec3 n, float eta) {
    float ci = dot(-i, n);
    float ct2 = 1.0 - eta * eta * (1.0 - ci * ci);
    vec3 t = eta * i + (eta * ci - sqrt(abs(ct2))) * n;
    return ct2 > 0.0 ? t : vec3(0.0);
  }
  float fres(vec3 i, vec3 n) {
    return clamp(fresnelBias + fresnelScale * pow(max(1.0 + dot(i, n), 0.0), fresnelPower), 0.0, 1.0);
  }
  // Brennan's correction for an environment of radius envRadius around envCenter.
  vec3 correct(vec3 v, vec3 p) {
    if (parallax == 0 || v == vec3(0.0)) return v;
    vec3 d = normalize(v);
    vec3 cp = p - envCenter;
    if (parallax == 1) return d + cp / envRadius;
    float b = dot(cp, d);
    float c = dot(cp, cp) - envRadius * envRadius;
    float disc = b * b - c;
    if (disc < 0.0) return d;
    float t = -b + sqrt(disc);
    return t <= 0.0 ? d : cp + d * t;
  }
  // The vertex programs: lookup vectors v[0..3] and the Fresnel factor at point p, normal n.
  void vertexStage(vec3 p, vec3 n, out vec3 v[4], out float factor) {
    vec3 i = p - eye;
    factor = 0.0;
    v[1] = vec3(0.0); v[2] = vec3(0.0); v[3] = vec3(0.0);
    if (MODEL == 1) {
      v[0] = correct(refr(normalize(i), n, etaRatio.x), p);
    } else {
      v[0] = correct(reflect(i, n), p);
      if (MODEL == 2) {
        vec3 iu = normalize(i);
        v[1] = correct(refr(iu, n, etaRatio.x), p);
        v[2] = correct(refr(iu, n, etaRatio.y), p);
        v[3] = correct(refr(iu, n, etaRatio.z), p);
        factor = fres(iu, n);
      } else if (MODEL == 3) {
        v[1] = n;
        v[2] = -normalize(i);
      }
    }
  }
  // The level a GPU picks for v with neighbours vx, vy (preview's cube_lod).
  float cubeLod(vec3 v, vec3 vx, vec3 vy) {
    vec3 a = abs(v);
    int axis = (a.x >= a.y && a.x >= a.z) ? 0 : (a.y >= a.z ? 1 : 2);
    ivec2 uw = axis == 0 ? ivec2(2, 1) : (axis == 1 ? ivec2(0, 2) : ivec2(0, 1));
    float ma = v[axis];
    if (ma == 0.0) return 0.0;
    vec2 pv = vec2(v[uw.x], v[uw.y]) / a[axis];
    float rho = 0.0;
    for (int k = 0; k < 2; k++) {
      vec3 q = k == 0 ? vx : vy;
      float m = q[axis] / sign(ma);
      if (!(m > 0.0)) return 1e30;
      rho = max(rho, length(vec2(q[uw.x], q[uw.y]) / m - pv));
    }
    return log2(rho * halfSize);
  }
  // With seams on: magenta where a lookup lands within a texel and a half of a face's edge.
  vec4 seamTint(vec3 d, vec4 c) {
    if (SEAMS == 0) return c;
    vec3 a = abs(d);
    float ma = max(a.x, max(a.y, a.z));
    vec2 st = a.x == ma ? d.yz : (a.y == ma ? d.xz : d.xy);
    float edge = max(abs(st.x), abs(st.y)) / ma;
    return edge > 1.0 - 3.0 / (2.0 * halfSize) ? mix(c, vec4(4.0, 0.0, 4.0, 1.0), 0.7) : c;
  }
  vec4 texCube(vec3 v, float lod) {
    return v == vec3(0.0) ? vec4(0.0) : seamTint(v, textureLod(env, v, lod));
  }
  vec4 background(vec3 d) {
    return seamTint(d, textureLod(env, d, bgLevel));
  }
  // The fragment programs, with the lookup vectors one pixel right (vx) and below (vy) for
  // the level of detail (ok false: unbounded footprint, the coarsest level).
  vec3 fragmentStage(vec3 v[4], float factor, vec2 uv, vec3 vx[4], vec3 vy[4], bool ok) {
    float refl = reflectivity, trans = transmittance, blur = 0.0, mask = 1.0;
    if (hasControl) {
      vec4 t = texture(control, uv);
      refl = t.x; trans = t.y; blur = t.z * maxLodBias; mask = t.w;
    }
    vec4 dc = hasDecal ? texture(decal, uv) : vec4(decalColor, 1.0);
    if (MODEL == 3) {
      vec3 bc = hasDecal ? baseColor * dc.rgb : baseColor;
      vec3 nn = normalize(v[1]);
      float nv = clamp(dot(nn, normalize(v[2])), 0.0, 1.0);
      vec3 f0c = mix(vec3(f0), bc, metallic);
      vec2 ab = texture(dfg, vec2(nv, clamp(roughness, 0.0, 1.0))).xy;
      vec3 pre = v[0] == vec3(0.0) ? vec3(0.0) : textureLod(chain, v[0], pbrLod + lodBias + blur).rgb;
      vec3 diffuse = bc * (1.0 - metallic) * textureLod(irradiance, nn, 0.0).rgb;
      return diffuse + pre * (f0c * ab.x + vec3(ab.y));
    }
    float lods[4] = float[4](0.0, 0.0, 0.0, 0.0);
    if (lodOn) {
      for (int k = 0; k < 4; k++) {
        float b = ok ? cubeLod(v[k], vx[k], vy[k]) : 1e30;
        lods[k] = b + lodBias + blur;
      }
    }
    if (MODEL == 0) return mix(dc, texCube(v[0], lods[0]), refl).rgb;
    if (MODEL == 1) return mix(dc, texCube(v[0], lods[0]), trans).rgb;
    vec3 reflected = texCube(v[0], lods[0]).rgb;
    vec3 refracted = vec3(texCube(v[1], lods[1]).x, texCube(v[2], lods[2]).y, texCube(v[3], lods[3]).z);
    float f = mask * factor + (1.0 - mask) * refl;
    return mix(refracted, reflected, f);
  }
#if EXACT
  // Glass done exactly (preview's glass.rs): unpolarised Fresnel reflectance of a smooth
  // interface met at cos ci, eta = n_incident / n_transmitted; 1 beyond the critical angle.
  float fresnelExact(float ci, float eta) {
    ci = clamp(ci, 0.0, 1.0);
    float st2 = eta * eta * (1.0 - ci * ci);
    if (st2 >= 1.0) return 1.0;
    float ct = sqrt(1.0 - st2);
    float rs = (eta * ci - ct) / (eta * ci + ct);
    float rp = (eta * ct - ci) / (eta * ct + ci);
    return clamp(0.5 * (rs * rs + rp * rp), 0.0, 1.0);
  }
  // Snell's law for unit i meeting unit n (facing i): false on total internal reflection.
  bool transmitExact(vec3 i, vec3 n, float eta, out vec3 t) {
    float ci = clamp(-dot(i, n), 0.0, 1.0);
    float k = 1.0 - eta * eta * (1.0 - ci * ci);
    t = vec3(0.0);
    if (k <= 0.0) return false;
    t = normalize(eta * i + (eta * ci - sqrt(k)) * n);
    return true;
  }
  // The light that comes out of the solid unit sphere for the eye ray i hitting it at p:
  // refracted in, then at each of up to 32 internal hits the part that leaves, the rest of
  // the series added to the last exit (glass::trace). The front reflectance in front.
  vec3 throughGlass(vec3 p, vec3 i, float eta, float lod, out float front) {
    vec3 n = p;
    front = fresnelExact(-dot(i, n), eta);
    float inside = 1.0 - front;
    vec3 sum = vec3(0.0), last = vec3(0.0), d, o;
    if (!(inside > 0.0) || !transmitExact(i, n, eta, d)) return sum;
    vec3 q = n;
    bool out_ = false;
    for (int k = 0; k < 32; k++) {
      float t = -2.0 * dot(q, d);
      if (t <= 0.0) break;
      q = normalize(q + d * t);
      float r = fresnelExact(dot(d, q), 1.0 / eta);
      if (r < 1.0 && transmitExact(d, -q, 1.0 / eta, o)) {
        last = texCube(correct(o, q), lod).rgb;
        sum += last * (inside * (1.0 - r));
        out_ = true;
      }
      inside *= r;
      d = normalize(reflect(d, q));
      if (inside < 1e-6) break;
    }
    return out_ ? sum + last * inside : sum;
  }
  // refract: the weighted rays, blended with the decal by transmittance (C7E4f); dispersion:
  // each channel traced with its own eta, the exact Fresnel split in place of the texts'
  // bias, scale and power. Level 0 plus the LOD bias and the control map's blur.
  vec3 shadeExact(vec3 p, vec2 uv) {
    float trans = transmittance, blur = 0.0;
    if (hasControl) {
      vec4 t = texture(control, uv);
      trans = t.y; blur = t.z * maxLodBias;
    }
    float lod = lodOn ? lodBias + blur : 0.0;
    vec3 n = normalize(p), i = normalize(p - eye);
    vec3 reflected = texCube(correct(reflect(i, n), p), lod).rgb;
    float front;
    if (MODEL == 1) {
      vec3 c = throughGlass(n, i, etaRatio.x, lod, front) + reflected * front;
      vec3 dc = hasDecal ? texture(decal, uv).rgb : decalColor;
      return mix(dc, c, trans);
    }
    vec3 c;
    for (int ch = 0; ch < 3; ch++) c[ch] = throughGlass(n, i, etaRatio[ch], lod, front)[ch] + front * reflected[ch];
    return c;
  }
#endif
  // Per fragment: the vertex stage at the exact hit, and where the rays one pixel right and
  // below meet the hit's tangent plane.
  vec3 shadeFragment(vec2 s, vec3 p) {
#if EXACT
    return shadeExact(p, sphereUv(normalize(p)));
#else
    vec3 n = normalize(p);
    vec2 uv = sphereUv(n);
    vec3 v[4], vx[4], vy[4]; float factor, f2;
    vertexStage(p, n, v, factor);
    bool ok = false;
    if (lodOn) {
      float plane = dot(p - eye, n);
      vec3 d2 = ray(s + vec2(1.0, 0.0));
      vec3 d3 = ray(s + vec2(0.0, 1.0));
      float den2 = dot(d2, n), den3 = dot(d3, n);
      ok = den2 < -1e-9 && den3 < -1e-9;
      if (ok) {
        vec3 p2 = eye + d2 * (plane / den2), p3 = eye + d3 * (plane / den3);
        vertexStage(p2, normalize(p2), vx, f2);
        vertexStage(p3, normalize(p3), vy, f2);
      }
    }
    return fragmentStage(v, factor, uv, vx, vy, ok);
#endif
  }
#if PER_VERTEX
  // The per-vertex mesh (preview's sphere::tessellate): vertex (i, j) of bands latitude
  // bands and 2 bands columns; pole vertices take their cell's middle u.
  vec3 meshPos(int i, int j) {
    if (i == 0) return vec3(0.0, 1.0, 0.0);
    if (i == bands) return vec3(0.0, -1.0, 0.0);
    float th = PI * float(i) / float(bands);
    float ph = 2.0 * PI * float(j) / float(2 * bands) - PI;
    return vec3(sin(th) * sin(ph), cos(th), sin(th) * cos(ph));
  }
  vec2 meshUv(int i, int j) {
    int m = 2 * bands;
    float u = ((i == 0 || i == bands) && j < m) ? (float(j) + 0.5) / float(m) : float(j) / float(m);
    return vec2(u, float(i) / float(bands));
  }
  // Barycentrics of the ray's meeting with the plane of (a, b, c), and its distance t.
  vec4 plane3(vec3 o, vec3 d, vec3 a, vec3 b, vec3 c) {
    vec3 e1 = b - a, e2 = c - a;
    vec3 h = cross(d, e2);
    float det = dot(e1, h);
    if (abs(det) < 1e-12) return vec4(-1.0, -1.0, -1.0, -1.0);
    vec3 sv = o - a;
    float u = dot(sv, h) / det;
    vec3 qv = cross(sv, e1);
    float w = dot(d, qv) / det;
    float t = dot(e2, qv) / det;
    return vec4(1.0 - u - w, u, w, t);
  }
  void blend(vec3 va[4], vec3 vb[4], vec3 vc[4], vec3 l, out vec3 o[4]) {
    for (int k = 0; k < 4; k++) o[k] = va[k] * l.x + vb[k] * l.y + vc[k] * l.z;
  }
  // Per vertex: the mesh triangle the ray meets (front faces, the hit's cell and its
  // neighbours), the vertex stage at its corners, varyings interpolated at the hit and, for
  // the level of detail, where the rays one pixel right and below meet its plane.
  vec3 shadeVertex(vec2 s, vec3 p, inout bool covered) {
    vec3 d = ray(s);
    int m = 2 * bands;
    float th = acos(clamp(p.y, -1.0, 1.0));
    int ci = int(floor(th / PI * float(bands)));
    int cj = int(floor((atan(p.x, p.z) + PI) / (2.0 * PI) * float(m)));
    float best = 1e30;
    ivec2 tri[3]; vec3 bary;
    bool found = false;
    for (int di = -1; di <= 1; di++) {
      int i = ci + di;
      if (i < 0 || i >= bands) continue;
      for (int dj = -1; dj <= 1; dj++) {
        int j = (cj + dj + m) % m;
        ivec2 A = ivec2(i, j), B = ivec2(i, j + 1), C = ivec2(i + 1, j), D = ivec2(i + 1, j + 1);
        for (int k = 0; k < 2; k++) {
          ivec2 t0 = A, t1 = C, t2 = D;
          if (i == 0) { if (k == 1) continue; }
          else if (i == bands - 1) { if (k == 1) continue; t2 = B; }
          else if (k == 1) { t1 = D; t2 = B; }
          vec3 a = meshPos(t0.x, t0.y), b = meshPos(t1.x, t1.y), c = meshPos(t2.x, t2.y);
          vec3 nrm = cross(b - a, c - a);
          if (dot(nrm, a + b + c) < 0.0) nrm = -nrm;
          if (dot(a - eye, nrm) >= 0.0) continue;
          vec4 h = plane3(eye, d, a, b, c);
          if (h.x < 0.0 || h.y < 0.0 || h.z < 0.0 || h.w <= 0.0 || h.w >= best) continue;
          best = h.w; tri[0] = t0; tri[1] = t1; tri[2] = t2; bary = h.xyz; found = true;
        }
      }
    }
    if (!found) { covered = false; return vec3(0.0); }
    vec3 P[3]; vec3 va[4], vb[4], vc[4]; float fa, fb, fc;
    for (int k = 0; k < 3; k++) P[k] = meshPos(tri[k].x, tri[k].y);
    vertexStage(P[0], P[0], va, fa);
    vertexStage(P[1], P[1], vb, fb);
    vertexStage(P[2], P[2], vc, fc);
    vec2 uv = meshUv(tri[0].x, tri[0].y) * bary.x + meshUv(tri[1].x, tri[1].y) * bary.y + meshUv(tri[2].x, tri[2].y) * bary.z;
    vec3 v[4], vx[4], vy[4];
    blend(va, vb, vc, bary, v);
    float factor = fa * bary.x + fb * bary.y + fc * bary.z;
    bool ok = lodOn;
    if (lodOn) {
      vec4 hx = plane3(eye, ray(s + vec2(1.0, 0.0)), P[0], P[1], P[2]);
      vec4 hy = plane3(eye, ray(s + vec2(0.0, 1.0)), P[0], P[1], P[2]);
      blend(va, vb, vc, hx.xyz, vx);
      blend(va, vb, vc, hy.xyz, vy);
    }
    return fragmentStage(v, factor, uv, vx, vy, ok);
  }
#endif
  vec3 shade(vec2 s) {
    vec3 d = ray(s);
    vec3 p;
    if (!hit(eye, d, p)) return background(d).rgb;
#if PER_VERTEX
    bool covered = true;
    vec3 c = shadeVertex(s, p, covered);
    return covered ? c : background(d).rgb;
#else
    return shadeFragment(s, p);
#endif
  }
  float curve(float x) {
    x = max(x, 0.0);
    if (tonemap == 1) return x / (1.0 + x);
    if (tonemap == 2) { x = min(x, 1e4); return clamp((x * (2.51 * x + 0.03)) / (x * (2.43 * x + 0.59) + 0.14), 0.0, 1.0); }
    return min(x, 1.0);
  }
  float srgb(float v) {
    v = clamp(v, 0.0, 1.0);
    return v <= 0.0031308 ? v * 12.92 : 1.055 * pow(v, 1.0 / 2.4) - 0.055;
  }
#if CROSS
  // The map as a horizontal cross (cubeforge's hcross: +Y above +Z, -X +Z +X -Z, -Y below),
  // each face as its image; black where no face is (as convert writes it).
  vec3 crossTexel(vec2 s) {
    ivec2 cell = ivec2(floor(s / crossCell));
    int face = -1;
    if (cell.y == 1) face = cell.x == 0 ? 1 : (cell.x == 1 ? 4 : (cell.x == 2 ? 0 : 5));
    else if (cell.x == 1) face = cell.y == 0 ? 2 : 3;
    if (face < 0) return vec3(0.0);
    vec2 st = (s - vec2(cell) * crossCell) / crossCell;
    float sc = 2.0 * st.x - 1.0, tc = 2.0 * st.y - 1.0;
    vec3 d = face == 0 ? vec3(1.0, -tc, -sc) : face == 1 ? vec3(-1.0, -tc, sc)
           : face == 2 ? vec3(sc, 1.0, tc) : face == 3 ? vec3(sc, -1.0, -tc)
           : face == 4 ? vec3(sc, -tc, 1.0) : vec3(-sc, -tc, -1.0);
    return background(d).rgb;
  }
#endif
  void main() {
    // Pixel (i, j) from the top left of this cell, as the CPU renderer counts them.
    vec2 px = vec2(floor(gl_FragCoord.x) - origin.x, size - 1.0 - floor(gl_FragCoord.y) + origin.y);
    vec3 acc = vec3(0.0);
    for (int k = 0; k < 16; k++) {
      if (k >= samples) break;
#if CROSS
      acc += crossTexel(px + offsets[k]);
#else
      acc += shade(px + offsets[k]);
#endif
    }
    vec3 c = acc / float(samples) * exp2(exposure);
    color = vec4(srgb(curve(c.r)), srgb(curve(c.g)), srgb(curve(c.b)), 1.0);
  }`,
};
