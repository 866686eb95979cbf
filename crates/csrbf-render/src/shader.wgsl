struct Globals {
    view_proj: mat4x4<f32>,
    eye: vec4<f32>,
    light_dir: array<vec4<f32>, 4>,
    light_color: array<vec4<f32>, 4>,
    // x: light count, y: flat shading, z: ambient
    params: vec4<f32>,
};
@group(0) @binding(0) var<uniform> g: Globals;

struct PartU {
    color: vec4<f32>,
    // x: textured
    flags: vec4<f32>,
};
@group(1) @binding(0) var<uniform> part: PartU;
@group(1) @binding(1) var tex: texture_2d<f32>;
@group(1) @binding(2) var samp: sampler;

struct VIn {
    @location(0) pos: vec3<f32>,
    @location(1) normal: vec3<f32>,
    @location(2) uv: vec2<f32>,
    @location(3) color: vec4<f32>,
};

struct VOut {
    @builtin(position) clip: vec4<f32>,
    @location(0) world: vec3<f32>,
    @location(1) normal: vec3<f32>,
    @location(2) uv: vec2<f32>,
    @location(3) color: vec4<f32>,
};

@vertex
fn vs_mesh(v: VIn) -> VOut {
    var o: VOut;
    o.clip = g.view_proj * vec4<f32>(v.pos, 1.0);
    o.world = v.pos;
    o.normal = v.normal;
    o.uv = v.uv;
    o.color = v.color;
    return o;
}

@fragment
fn fs_mesh(i: VOut) -> @location(0) vec4<f32> {
    // Derivatives and texture sampling first, in uniform control flow.
    let face_n = normalize(cross(dpdx(i.world), dpdy(i.world)));
    let texel = textureSample(tex, samp, vec2<f32>(i.uv.x, 1.0 - i.uv.y));
    var n = normalize(i.normal);
    n = select(n, face_n, g.params.y > 0.5);
    let to_eye = normalize(g.eye.xyz - i.world);
    // Two-sided: light the side that faces the eye.
    n = select(n, -n, dot(n, to_eye) < 0.0);
    var base = part.color * i.color;
    base = select(base, base * texel, part.flags.x > 0.5);
    var light = vec3<f32>(g.params.z);
    let count = i32(g.params.x);
    for (var k = 0; k < 4; k = k + 1) {
        if (k < count) {
            let l = -normalize(g.light_dir[k].xyz);
            let diffuse = max(dot(n, l), 0.0);
            let h = normalize(l + to_eye);
            let spec = pow(max(dot(n, h), 0.0), 48.0) * 0.25;
            light = light + g.light_color[k].rgb * (diffuse + spec);
        }
    }
    return vec4<f32>(base.rgb * light, base.a);
}

struct LIn {
    @location(0) pos: vec3<f32>,
    @location(1) color: vec4<f32>,
};

struct LOut {
    @builtin(position) clip: vec4<f32>,
    @location(0) color: vec4<f32>,
};

@vertex
fn vs_line(v: LIn) -> LOut {
    var o: LOut;
    o.clip = g.view_proj * vec4<f32>(v.pos, 1.0);
    o.color = v.color;
    return o;
}

@fragment
fn fs_line(i: LOut) -> @location(0) vec4<f32> {
    return i.color;
}
